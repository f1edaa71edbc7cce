//! The cleaning steps of Smith 1991, §2, as one library: each turns a flat
//! UniGrafix [`ug::Model`] into a cleaner one and reports what it did. The
//! tools `ugplanar`, `ugvlmerge`, `ugflip`, `ugisect`, `ugcopl` and `ugclean`
//! are thin front ends to these modules, in the order the pipeline runs them:
//!
//! | module | tool | entry | what |
//! |---|---|---|---|
//! | [`planar`] | ugplanar | [`planar::planarize`] | non-planar faces into triangles (§2.2) |
//! | [`group`] | ugvlmerge | [`group::vlmerge`] | merge vertices, remove T-vertices, join coplanar faces (§2.4) |
//! | [`orient`] | ugflip | [`orient::orient`] | consistent, outward or inward orientation (§2.3) |
//! | [`isect`] | ugisect | [`isect::isect`] | cut intersecting faces (§2.5) |
//! | [`copl`] | ugcopl | [`copl::copl`] | cut coplanar overlapping faces (§2.5) |
//! | [`coincident`] | ugclean | [`coincident::clean`] | drop one face of each coincident pair (§2.6) |
//! | [`enclosed`] | ugclean | [`enclosed::remove`] | drop the faces no light can reach (inside solids) |
//! | [`group`], [`orient`] | ugclean | [`group::collapse_tents`], [`orient::agree`] | join tents' tips, make orientation consistent across the edges the cuts joined |
//!
//! [`clean()`] runs ugclean's steps in its order.
//!
//! Every step takes the distance tolerance `eps` (model units) explicitly;
//! pair tests come from the `check` crate, so a step removes exactly what
//! `ugcheck` reports.

pub mod coincident;
pub mod copl;
pub mod enclosed;
pub mod group;
pub mod isect;
pub mod orient;
pub mod pieces;
pub mod planar;

use ug::Model;

/// What [`clean()`]'s steps did.
pub struct Cleaned {
    pub coincident: coincident::Stats,
    /// `None` when the enclosed faces were kept.
    pub enclosed: Option<enclosed::Stats>,
    pub tents: group::Tents,
    /// Labels of the faces [`orient::agree`] turned.
    pub turned: Vec<String>,
    /// The coincident pairs the turns made (a face turned over onto the
    /// face back to back with it: a table top thinner than epsilon), and
    /// the faces removed of them.
    pub turned_coincident: coincident::Stats,
}

/// ugclean's steps after it settles its input: one face of every coincident
/// pair goes, then the enclosed faces (unless `keep_enclosed`), then tents'
/// tips join a neighbour, and last the faces walking a shared edge the same
/// way as their neighbours turn to agree. Where a turned face is then
/// coincident with another (it lay back to back with it), the coincident
/// step runs again on the turned faces, and the turns once more after it.
pub fn clean(model: &Model, eps: f64, keep_enclosed: bool) -> (Model, Cleaned) {
    let (out, coincident) = coincident::clean(model, eps);
    let (out, enclosed) = if keep_enclosed {
        (out, None)
    } else {
        let (out, st) = enclosed::remove(&out, eps);
        (out, Some(st))
    };
    let (out, tents) = group::collapse_tents(out, eps, &coincident.bent);
    let (mut out, ids) = orient::agree(out);
    let labels = group::face_labels(&out);
    let mut turned: Vec<String> = ids
        .iter()
        .map(|f| labels[f.idx()].clone().unwrap_or_default())
        .collect();
    let mut turned_coincident = coincident::Stats::default();
    if !ids.is_empty() {
        let mut among = vec![false; out.faces.len()];
        for f in &ids {
            among[f.idx()] = true;
        }
        let (next, st) = coincident::clean_near(&out, eps, &among);
        if !st.removed.is_empty() {
            let (next, more) = orient::agree(next);
            let labels = group::face_labels(&next);
            turned.extend(
                more.iter()
                    .map(|f| labels[f.idx()].clone().unwrap_or_default()),
            );
            out = next;
            turned_coincident = st;
        }
    }
    (
        out,
        Cleaned {
            coincident,
            enclosed,
            tents,
            turned,
            turned_coincident,
        },
    )
}

/// The root of `x` in a union-find forest (`parent[r] == r` at a root),
/// halving the path on the way.
pub(crate) fn root(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Joins the sets of `a` and `b`; the smaller root stands for both (so a
/// set's root is its least member).
pub(crate) fn join(parent: &mut [usize], a: usize, b: usize) {
    let (a, b) = (root(parent, a), root(parent, b));
    if a != b {
        parent[a.max(b)] = a.min(b);
    }
}
