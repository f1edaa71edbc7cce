//! ugclean: remove coincident faces, then enclosed ones.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugclean < in.ug > clean.ug
  ugvlmerge < in.ug | ugisect | ugcopl | ugclean -v | ugcut -l 2
  ugclean -e 0.001 model.ug -o clean.ug
  ugclean --keep-enclosed < in.ug > clean.ug   # only the coincident faces";

/// Remove one face of every coincident pair (coplanar, same region, facing
/// the same way): with the same material the later face goes; with different
/// materials the piece from the larger original surface goes (the floor under
/// the rug), read from ugcopl's `{ugcopl origin NAME area A}` annotations or
/// measured as the connected coplanar surface of the face's material.
/// Faces back to back (a zero-thickness wall's two sides) stay.
///
/// Then the enclosed faces go: those that no light can reach and no one
/// see, because everything in front of them is the back of some face — the
/// floor under a wall's foot, the part of a wall inside the wall crossing
/// it, the legs of a table below the floor. Rays from each face decide
/// (see README); emitters, faces seen from outside and closed dark rooms
/// stay. This changes the area per material; --keep-enclosed keeps them.
///
/// Last, a tent's tip (a contour vertex within epsilon of the short chord,
/// under 2 epsilon, between its neighbours: no mesher covers it without a
/// sliver, and ugcheck counts it as degenerate) joins its nearer neighbour
/// (or the other, or each face through it takes the neighbour on its own
/// side, where that keeps faces from crossing or overlapping).
///
/// Finally, where two faces walk a shared edge the same way (the cuts joined
/// parts ugflip oriented apart), the faces of the lesser area in each part
/// joined by such edges turn to agree with the rest.
/// Instances are flattened first.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Keep the enclosed faces (those that only the backs of faces surround:
    /// the floor under a wall's foot, the part of a wall inside the wall
    /// crossing it); by default they are removed. With it, the area of
    /// every material is kept.
    #[arg(long)]
    keep_enclosed: bool,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        let model = clean::group::settle_warned(model, eps, c.quiet, c.verbose > 0)?;
        let (out, cl) = clean::clean(&model, eps, args.keep_enclosed);
        let clean::Cleaned {
            coincident: st,
            enclosed,
            tents,
            turned,
            turned_coincident,
        } = cl;
        if c.verbose > 0 {
            eprintln!(
                "epsilon {eps:e}; {} coincident pairs; removed {} faces, area {}; {} kept faces took a removed twin's contours; {} vertex records of kept faces replaced by the removed twins'; {} edges that two contours of a face then walked both ways joined",
                st.pairs,
                st.removed.len(),
                st.area_removed,
                st.reshaped,
                st.snapped,
                st.joined
            );
            for (r, k, why) in &st.removed {
                eprintln!("  removed {r} (kept {k}): {why}");
            }
            print_dropped("the shared records", st.dropped.iter());
            if let Some(enc) = enclosed {
                eprintln!(
                    "{} enclosed faces removed, area {}; {} kept where removing them would leave an edge walked twice the same way",
                    enc.removed.len(),
                    enc.area_removed,
                    enc.spared
                );
                if c.verbose > 1 {
                    for r in &enc.removed {
                        eprintln!("  enclosed {r}");
                    }
                }
            }
            eprintln!(
                "{} faces left more than epsilon off their plane, folded into triangles; {} points joined to a corner just beyond epsilon; {} tents' tips joined to a neighbour; {} coincident pairs they made, {} faces removed, area {}",
                tents.folded,
                tents.corners,
                tents.joined,
                tents.coincident.pairs,
                tents.coincident.removed.len(),
                tents.coincident.area_removed
            );
            for (r, k, why) in &tents.coincident.removed {
                eprintln!("  removed {r} (kept {k}): {why}");
            }
            print_dropped(
                "the joins",
                tents.dropped.iter().chain(&tents.coincident.dropped),
            );
            eprintln!(
                "{} faces turned to agree with their neighbours across the edges the cuts joined",
                turned.len()
            );
            if c.verbose > 1 {
                for t in &turned {
                    eprintln!("  turned {t}");
                }
            }
            if turned_coincident.pairs > 0 {
                eprintln!(
                    "{} coincident pairs the turns made, {} faces removed, area {}",
                    turned_coincident.pairs,
                    turned_coincident.removed.len(),
                    turned_coincident.area_removed
                );
                for (r, k, why) in &turned_coincident.removed {
                    eprintln!("  removed {r} (kept {k}): {why}");
                }
                print_dropped("the turns' pairs", turned_coincident.dropped.iter());
            }
        }
        Ok(out)
    })
}

/// The `-v` lines for faces `what` left without area: a count, then each.
fn print_dropped<'a>(what: &str, dropped: impl Iterator<Item = &'a clean::group::Dropped>) {
    let dropped: Vec<_> = dropped.collect();
    if !dropped.is_empty() {
        eprintln!("{} faces {what} left without area, dropped", dropped.len());
        for d in dropped {
            eprintln!("  dropped {}: {}", d.face, d.reason);
        }
    }
}
