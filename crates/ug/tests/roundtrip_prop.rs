//! Property: any valid Model written as UG reads back as the same Model,
//! and writing is idempotent.
//!
//! Models are built from a random list of operations by a builder that keeps
//! them valid the way the parser would: names unique per namespace (vertices,
//! faces and wires, instances per def scope; materials and defs globally),
//! arena order equal to statement order (a def is stored at its `end`),
//! vertices resolved in their scope (forward references included), materials
//! resolved anywhere, instances only of defs already ended.

use std::collections::HashSet;

use glam::DVec3;
use proptest::prelude::*;
use ug::*;

// ---------- random ingredients ----------

/// A name from a safe alphabet (letters, digits, `:_#.`), sometimes with other
/// printable ASCII; material names start with a letter so that they never read
/// as a number or a transform flag where a colour is expected.
fn name(material: bool) -> BoxedStrategy<String> {
    let first = if material {
        "[a-zA-Z]"
    } else {
        "[a-zA-Z0-9:_#.]"
    };
    let re = |r: String| proptest::string::string_regex(&r).expect("valid regex");
    prop_oneof![
        4 => re(format!("{first}[a-zA-Z0-9:_#.]{{0,7}}")),
        1 => re(format!("{first}[!-'*-:<-z|~]{{0,5}}")),
    ]
    .boxed()
}

/// Finite numbers, with the awkward ones well represented.
fn num() -> BoxedStrategy<f64> {
    prop_oneof![
        3 => (-1000i32..1000).prop_map(|k| f64::from(k) / 8.0),
        3 => any::<f64>().prop_filter("finite", |v| v.is_finite()),
        1 => prop_oneof![
            Just(0.0),
            Just(-0.0),
            Just(f64::MIN_POSITIVE),
            Just(-f64::MIN_POSITIVE),
            Just(5e-324),
            Just(-5e-324),
            Just(f64::MAX),
            Just(f64::MIN),
            Just(1e-300),
            Just(1e300),
            Just(0.1),
            Just(1.0 / 3.0),
            Just(123456789012345680000.0),
        ],
    ]
    .boxed()
}

/// Text with no braces, sometimes with one nested balanced `{ … }` group.
fn braced_text() -> BoxedStrategy<String> {
    prop_oneof![
        "[^{}]{0,20}".prop_map(String::from),
        ("[^{}]{0,8}", "[^{}]{0,8}", "[^{}]{0,8}").prop_map(|(a, b, c)| format!("{a}{{{b}}}{c}")),
    ]
    .boxed()
}

/// Text with no parentheses, sometimes with nested balanced `( … )` groups.
fn paren_text() -> BoxedStrategy<String> {
    prop_oneof![
        "[^()]{0,20}".prop_map(String::from),
        ("[^()]{0,8}", "[^()]{0,8}", "[^()]{0,8}").prop_map(|(a, b, c)| format!("{a}({b}(){c})")),
    ]
    .boxed()
}

/// Words of a raw statement as the parser normalises them: single spaces,
/// parentheses as separate words, balanced.
fn raw_words() -> BoxedStrategy<String> {
    let word = "[!-'*-:<-z|~]{1,6}";
    proptest::collection::vec(
        prop_oneof![
            3 => word.prop_map(|w: String| w),
            1 => proptest::collection::vec(word, 0..3).prop_map(|ws| {
                let mut v = vec!["(".to_string()];
                v.extend(ws);
                v.push(")".to_string());
                v.join(" ")
            }),
        ],
        0..5,
    )
    .prop_map(|ws| ws.join(" "))
    .boxed()
}

const KEYWORDS: [&str; 13] = [
    "c_rgb", "c", "defmat", "v", "f", "w", "def", "end", "i", "a", "l", "cam", "include",
];

#[derive(Clone, Debug)]
enum MatPlan {
    Rgb([f64; 3]),
    Lhs(Vec<f64>),
    Defmat {
        diffuse: Option<[f64; 3]>,
        emission: Option<[f64; 3]>,
        other: Vec<(String, Vec<String>)>,
    },
}

fn rgb() -> impl Strategy<Value = [f64; 3]> {
    [num(), num(), num()]
}

fn mat_plan() -> BoxedStrategy<MatPlan> {
    let other_key = name(true).prop_filter("not a defmat keyword", |k| {
        !matches!(k.as_str(), "end" | "diffuse_rgb" | "emission_rgb")
    });
    let other_words = proptest::collection::vec("[!-'*-:<-z|~]{1,6}", 0..3);
    prop_oneof![
        rgb().prop_map(MatPlan::Rgb),
        proptest::collection::vec(num(), 1..=4).prop_map(MatPlan::Lhs),
        (
            proptest::option::of(rgb()),
            proptest::option::of(rgb().prop_map(|c| c.map(f64::abs))),
            proptest::collection::vec((other_key, other_words), 0..3),
        )
            .prop_map(|(diffuse, emission, other)| MatPlan::Defmat {
                diffuse,
                emission,
                other
            }),
    ]
    .boxed()
}

fn transform() -> BoxedStrategy<Transform> {
    (
        0..TransformOp::ALL.len(),
        proptest::collection::vec(num(), 16),
        num(),
    )
        .prop_map(|(k, nums, w)| {
            let op = TransformOp::ALL[k];
            let mut args: Vec<f64> = nums[..op.arity()].to_vec();
            if op == TransformOp::M4 {
                // Affine: last row 0 0 0 w, w non-zero.
                args[12] = 0.0;
                args[13] = 0.0;
                args[14] = 0.0;
                args[15] = if w == 0.0 { 1.0 } else { w };
            }
            Transform { op, args }
        })
        .boxed()
}

#[derive(Clone, Debug)]
enum Op {
    Comment(String),
    Material(String, MatPlan),
    Vertex(String, [f64; 3], Option<u32>),
    /// Face (or wire): name, contours as raw vertex choices, material choice.
    Geom(bool, Option<String>, Vec<Vec<u32>>, Option<u32>),
    DefStart(String),
    DefEnd,
    Instance(
        Option<String>,
        u32,
        Option<u32>,
        Vec<Transform>,
        Option<(u32, Vec<Transform>)>,
    ),
    Light(String),
    Camera(String),
    Escape(String),
    Unknown(String, String),
    Include(String),
}

fn op() -> BoxedStrategy<Op> {
    let mat = proptest::option::of(any::<u32>());
    prop_oneof![
        1 => braced_text().prop_map(Op::Comment),
        2 => (name(true), mat_plan()).prop_map(|(n, p)| Op::Material(n, p)),
        8 => (name(false), [num(), num(), num()], mat.clone()).prop_map(|(n, p, c)| Op::Vertex(n, p, c)),
        4 => (
            any::<bool>(),
            proptest::option::of(name(false)),
            proptest::collection::vec(proptest::collection::vec(any::<u32>(), 3..6), 1..4),
            mat.clone()
        )
            .prop_map(|(wire, n, cs, m)| {
                // Wires may have two vertices per polyline.
                let cs = if wire {
                    cs.into_iter().map(|c| c[..c.len() - 1].to_vec()).collect()
                } else {
                    cs
                };
                Op::Geom(wire, n, cs, m)
            }),
        2 => name(false).prop_map(Op::DefStart),
        2 => Just(Op::DefEnd),
        3 => (
            proptest::option::of(name(false)),
            any::<u32>(),
            mat,
            proptest::collection::vec(transform(), 0..4),
            proptest::option::of((any::<u32>(), proptest::collection::vec(transform(), 0..3))),
        )
            .prop_map(|(n, d, c, ts, a)| Op::Instance(n, d, c, ts, a)),
        1 => raw_words().prop_map(Op::Light),
        1 => raw_words().prop_map(Op::Camera),
        1 => paren_text().prop_map(Op::Escape),
        1 => (
            name(false).prop_filter("not a keyword", |k| !KEYWORDS.contains(&k.as_str())),
            raw_words()
        )
            .prop_map(|(k, t)| Op::Unknown(k, t)),
        1 => "[a-zA-Z0-9_./'\"-]{1,12}".prop_map(Op::Include),
    ]
    .boxed()
}

// ---------- building a valid Model ----------

#[derive(Default)]
struct Scope {
    def_name: Option<String>,
    items: Vec<Item>,
    vnames: HashSet<String>,
    gnames: HashSet<String>,
    inames: HashSet<String>,
    verts: Vec<VertexId>,
    /// (is wire, id, raw contours) to resolve when the scope ends.
    geoms: Vec<(bool, u32, Vec<Vec<u32>>)>,
}

#[derive(Clone, Copy)]
enum Site {
    Vertex(u32),
    Face(u32),
    Wire(u32),
    Instance(u32),
}

#[derive(Default)]
struct Builder {
    m: Model,
    mat_names: HashSet<String>,
    def_names: HashSet<String>,
    scopes: Vec<Scope>,
    mat_refs: Vec<(Site, u32)>,
}

/// `base`, or `base_2`, `base_3`, … — the first not in `set` (which takes it).
fn fresh(set: &mut HashSet<String>, base: &str) -> String {
    let mut cand = base.to_string();
    let mut k = 2;
    while set.contains(&cand) {
        cand = format!("{base}_{k}");
        k += 1;
    }
    set.insert(cand.clone());
    cand
}

impl Builder {
    fn scope(&mut self) -> &mut Scope {
        self.scopes.last_mut().expect("a scope is open")
    }

    fn apply(&mut self, op: Op) {
        match op {
            Op::Comment(t) => self.scope().items.push(Item::Comment(t)),
            Op::Material(n, plan) => {
                let name = fresh(&mut self.mat_names, &n);
                let def = match plan {
                    MatPlan::Rgb(c) => MaterialDef::Rgb(c),
                    MatPlan::Lhs(v) => MaterialDef::Lhs(v),
                    MatPlan::Defmat {
                        diffuse,
                        emission,
                        other,
                    } => MaterialDef::Defmat(Defmat {
                        diffuse,
                        emission,
                        other,
                    }),
                };
                let id = MaterialId(self.m.materials.len() as u32);
                self.m.materials.push(Material { name, def });
                self.scope().items.push(Item::Material(id));
            }
            Op::Vertex(n, p, c) => {
                let name = fresh(&mut self.scope().vnames, &n);
                self.push_vertex(name, p, c);
            }
            Op::Geom(wire, n, cs, mat) => {
                let name = n.map(|n| fresh(&mut self.scope().gnames, &n));
                let id;
                if wire {
                    id = self.m.wires.len() as u32;
                    self.m.wires.push(Wire {
                        name,
                        polylines: vec![],
                        material: None,
                    });
                    self.scope().items.push(Item::Wire(WireId(id)));
                    if let Some(c) = mat {
                        self.mat_refs.push((Site::Wire(id), c));
                    }
                } else {
                    id = self.m.faces.len() as u32;
                    self.m.faces.push(Face {
                        name,
                        contours: vec![],
                        material: None,
                    });
                    self.scope().items.push(Item::Face(FaceId(id)));
                    if let Some(c) = mat {
                        self.mat_refs.push((Site::Face(id), c));
                    }
                }
                self.scope().geoms.push((wire, id, cs));
            }
            Op::DefStart(n) => {
                if self.scopes.len() < 4 {
                    // The name is checked against the defs ended so far and the open ones.
                    let mut taken = self.def_names.clone();
                    taken.extend(self.scopes.iter().filter_map(|s| s.def_name.clone()));
                    let name = fresh(&mut taken, &n);
                    self.scopes.push(Scope {
                        def_name: Some(name),
                        ..Scope::default()
                    });
                }
            }
            Op::DefEnd => {
                if self.scopes.len() > 1 {
                    self.end_def();
                }
            }
            Op::Instance(n, d, c, transforms, array) => {
                if self.m.defs.is_empty() {
                    return;
                }
                let def = DefId(d % self.m.defs.len() as u32);
                let name = n.map(|n| fresh(&mut self.scope().inames, &n));
                let id = self.m.instances.len() as u32;
                self.m.instances.push(Instance {
                    name,
                    def,
                    color: None,
                    transforms,
                    array: array.map(|(count, step)| ArraySpec { count, step }),
                });
                if let Some(c) = c {
                    self.mat_refs.push((Site::Instance(id), c));
                }
                self.scope().items.push(Item::Instance(InstanceId(id)));
            }
            Op::Light(t) => self.scope().items.push(Item::Light(Raw {
                keyword: "l".into(),
                text: t,
            })),
            Op::Camera(t) => self.scope().items.push(Item::Camera(Raw {
                keyword: "cam".into(),
                text: t,
            })),
            Op::Escape(t) => self.scope().items.push(Item::Escape(t)),
            Op::Unknown(k, t) => self.scope().items.push(Item::Unknown(Raw {
                keyword: k,
                text: t,
            })),
            Op::Include(f) => self.scope().items.push(Item::Include(f)),
        }
    }

    fn push_vertex(&mut self, name: String, p: [f64; 3], c: Option<u32>) {
        let id = self.m.vertices.len() as u32;
        self.m.vertices.push(Vertex {
            name,
            pos: DVec3::from_array(p),
            color: None,
        });
        if let Some(c) = c {
            self.mat_refs.push((Site::Vertex(id), c));
        }
        let s = self.scope();
        s.verts.push(VertexId(id));
        s.items.push(Item::Vertex(VertexId(id)));
    }

    /// Resolves the open scope's faces and wires against its vertices.
    fn close_scope(&mut self) -> Scope {
        if !self.scope().geoms.is_empty() && self.scope().verts.is_empty() {
            let name = fresh(&mut self.scope().vnames, "v");
            self.push_vertex(name, [0.0; 3], None);
        }
        let s = self.scopes.pop().expect("a scope is open");
        for (wire, id, cs) in &s.geoms {
            let cs: Vec<Vec<VertexId>> = cs
                .iter()
                .map(|c| {
                    c.iter()
                        .map(|&k| s.verts[k as usize % s.verts.len()])
                        .collect()
                })
                .collect();
            if *wire {
                self.m.wires[*id as usize].polylines = cs;
            } else {
                self.m.faces[*id as usize].contours = cs;
            }
        }
        s
    }

    fn end_def(&mut self) {
        let s = self.close_scope();
        let name = s.def_name.expect("a def scope");
        self.def_names.insert(name.clone());
        let id = DefId(self.m.defs.len() as u32);
        self.m.defs.push(Def {
            name,
            items: s.items,
        });
        self.scope().items.push(Item::Def(id));
    }

    fn build(ops: Vec<Op>) -> Model {
        let mut b = Builder::default();
        b.scopes.push(Scope::default());
        for op in ops {
            b.apply(op);
        }
        while b.scopes.len() > 1 {
            b.end_def();
        }
        let top = b.close_scope();
        b.m.items = top.items;
        let n = b.m.materials.len() as u32;
        for (site, c) in std::mem::take(&mut b.mat_refs) {
            let mat = (n > 0).then(|| MaterialId(c % n));
            match site {
                Site::Vertex(k) => b.m.vertices[k as usize].color = mat,
                Site::Face(k) => b.m.faces[k as usize].material = mat,
                Site::Wire(k) => b.m.wires[k as usize].material = mat,
                Site::Instance(k) => b.m.instances[k as usize].color = mat,
            }
        }
        b.m
    }
}

fn reparse(text: &str, keep_includes: bool) -> Result<Model, Diagnostic> {
    let opts = ParseOptions {
        strict: false,
        includes: if keep_includes {
            IncludeMode::Keep
        } else {
            IncludeMode::Resolve
        },
        limits: false,
    };
    ug::parse_with(text.as_bytes(), "written.ug", None, &opts).map(|p| p.model)
}

fn has_include(items: &[Item], m: &Model) -> bool {
    items.iter().any(|it| match it {
        Item::Include(_) => true,
        Item::Def(d) => has_include(&m.defs[d.idx()].items, m),
        _ => false,
    })
}

/// What the parser reads back from the writer's text: every vertex statement
/// moved up to just before the first face or wire of its list that names it
/// (the writer defines vertices before use), and the vertex arena renumbered
/// in the new statement order.
fn hoisted(m: &Model) -> Model {
    fn list(m: &Model, items: &[Item]) -> Vec<Item> {
        let mut at = std::collections::HashMap::new();
        for (k, it) in items.iter().enumerate() {
            if let Item::Vertex(v) = it {
                at.entry(*v).or_insert(k);
            }
        }
        let mut early = HashSet::new();
        let mut out = Vec::new();
        let names_of = |it: &Item| -> Vec<VertexId> {
            match it {
                Item::Face(f) => m.faces[f.idx()].contours.concat(),
                Item::Wire(w) => m.wires[w.idx()].polylines.concat(),
                _ => Vec::new(),
            }
        };
        for (k, it) in items.iter().enumerate() {
            // Vertices of a face go before the comments just before it.
            if matches!(it, Item::Comment(_))
                && (k == 0 || !matches!(items[k - 1], Item::Comment(_)))
                && let Some(j) = (k..items.len()).find(|&j| !matches!(items[j], Item::Comment(_)))
            {
                for v in names_of(&items[j]) {
                    if at.get(&v).is_some_and(|&p| p > k) && early.insert(v) {
                        out.push(Item::Vertex(v));
                    }
                }
            }
            let names: Vec<VertexId> = match it {
                Item::Face(f) => m.faces[f.idx()].contours.concat(),
                Item::Wire(w) => m.wires[w.idx()].polylines.concat(),
                Item::Vertex(v) if early.contains(v) => continue,
                _ => Vec::new(),
            };
            for v in names {
                if at.get(&v).is_some_and(|&p| p > k) && early.insert(v) {
                    out.push(Item::Vertex(v));
                }
            }
            out.push(it.clone());
        }
        out
    }
    let mut m2 = m.clone();
    m2.items = list(m, &m.items);
    for d in 0..m.defs.len() {
        m2.defs[d].items = list(m, &m.defs[d].items);
    }
    // New vertex ids in text order (def bodies where the def is written).
    fn order(m: &Model, items: &[Item], out: &mut Vec<VertexId>) {
        for it in items {
            match it {
                Item::Vertex(v) => out.push(*v),
                Item::Def(d) => order(m, &m.defs[d.idx()].items, out),
                _ => {}
            }
        }
    }
    let mut seq = Vec::new();
    order(&m2, &m2.items, &mut seq);
    if seq.len() != m.vertices.len() {
        return m2; // vertices without statements: leave the numbering alone
    }
    let mut new_id = vec![VertexId(0); m.vertices.len()];
    for (k, v) in seq.iter().enumerate() {
        new_id[v.idx()] = VertexId(k as u32);
    }
    m2.vertices = seq.iter().map(|v| m.vertices[v.idx()].clone()).collect();
    let remap = |c: &mut Vec<VertexId>| c.iter_mut().for_each(|v| *v = new_id[v.idx()]);
    for f in &mut m2.faces {
        f.contours.iter_mut().for_each(remap);
    }
    for w in &mut m2.wires {
        w.polylines.iter_mut().for_each(remap);
    }
    fn items_remap(items: &mut [Item], new_id: &[VertexId]) {
        for it in items {
            if let Item::Vertex(v) = it {
                *v = new_id[v.idx()];
            }
        }
    }
    items_remap(&mut m2.items, &new_id);
    for d in &mut m2.defs {
        items_remap(&mut d.items, &new_id);
    }
    m2
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 512,
        max_shrink_iters: 20_000,
        ..ProptestConfig::default()
    })]

    #[test]
    fn parse_of_write_is_identity(ops in proptest::collection::vec(op(), 0..60)) {
        let m = Builder::build(ops);
        let text = ug::write_string(&m);
        let keep = has_include(&m.items, &m);
        let back = reparse(&text, keep);
        prop_assert!(back.is_ok(), "written text does not parse: {}\n--- text\n{}", back.unwrap_err(), text);
        let back = back.unwrap();
        prop_assert_eq!(&back, &hoisted(&m), "--- text\n{}", text);
        prop_assert_eq!(ug::write_string(&back), text);
    }

    #[test]
    fn flattening_a_valid_model_gives_a_valid_flat_model(
        ops in proptest::collection::vec(op(), 0..40)
    ) {
        let m = Builder::build(ops);
        if has_include(&m.items, &m) {
            return Ok(());
        }
        let limits = FlattenLimits { max_vertices: 20_000, max_faces: 20_000 };
        // Random transforms may overflow and random arrays may be huge: both are errors, not panics.
        if let Ok(flat) = m.flatten_with(limits) {
            prop_assert!(flat.is_flat());
            let text = ug::write_string(&flat);
            let back = reparse(&text, false);
            prop_assert!(back.is_ok(), "flattened text does not parse: {}\n--- text\n{}", back.unwrap_err(), text);
            prop_assert_eq!(&back.unwrap(), &hoisted(&flat));
        }
    }
}

#[test]
fn the_builder_makes_models_with_everything() {
    // A fixed operation list exercising every branch, as a sanity check of the builder.
    let ops = vec![
        Op::Material("red".into(), MatPlan::Rgb([1.0, 0.0, 0.0])),
        Op::Geom(false, Some("t".into()), vec![vec![0, 1, 2]], Some(0)),
        Op::Vertex("a".into(), [0.0, 0.0, 0.0], None),
        Op::Vertex("a".into(), [1.0, 0.0, 0.0], Some(7)),
        Op::DefStart("d".into()),
        Op::Vertex("a".into(), [0.0, 0.0, -0.0], None),
        Op::Geom(true, Some("t".into()), vec![vec![0, 0]], None),
        Op::DefEnd,
        Op::Instance(Some("x".into()), 0, Some(0), vec![], Some((3, vec![]))),
        Op::Escape("e (f) g".into()),
        Op::Comment("c {d} e".into()),
        Op::Unknown("zz".into(), "( 1 ) 2".into()),
    ];
    let m = Builder::build(ops);
    assert_eq!(m.vertices.len(), 3);
    assert_eq!(m.vertices[1].name, "a_2");
    assert_eq!(
        m.faces[0].contours,
        vec![vec![VertexId(0), VertexId(1), VertexId(0)]]
    );
    let text = ug::write_string(&m);
    assert_eq!(reparse(&text, false).unwrap(), hoisted(&m), "{text}");
}
