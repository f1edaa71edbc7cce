//! The [`Mesh`]: a flat model plus its winged-edge topology, queries and edits.

use geom::Plane;
use glam::DVec3;
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, FaceId, Item, Material, MaterialId, Model, Vertex, VertexId};

use crate::order::{NIL, Order};
use crate::{Edge, EdgeId, EdgeUse, MergeError, Repair};

/// A flat UniGrafix model with winged-edge topology over its top-level faces.
/// See the crate documentation for the structure.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// The arenas. `items` is the statement list as it was at construction
    /// (edits do not update it; `order` holds the live statement order).
    pub(crate) model: Model,
    pub(crate) face_live: Vec<bool>,
    /// Per face, per contour, per position: the edge from that vertex to the next.
    pub(crate) contour_edges: Vec<Vec<Vec<EdgeId>>>,
    pub(crate) edges: Vec<Edge>,
    /// Lookup only (never iterated): (v0, v1) with v0 < v1 → live edge.
    pub(crate) edge_map: FxHashMap<(VertexId, VertexId), EdgeId>,
    /// Per vertex: its live edges, ascending.
    pub(crate) vertex_edges: Vec<Vec<EdgeId>>,
    pub(crate) vertex_live: Vec<bool>,
    pub(crate) order: Order,
    pub(crate) face_slot: Vec<u32>,
    pub(crate) vertex_slot: Vec<u32>,
    last_vertex_slot: u32,
    last_material_slot: u32,
    /// Lookup only: every vertex name in use (also of removed vertices).
    vertex_names: FxHashSet<String>,
    /// Lookup only: every face and wire name in use (they share a namespace).
    face_names: FxHashSet<String>,
    repairs: Vec<Repair>,
    pub(crate) live_faces: usize,
    pub(crate) live_edges: usize,
    /// Edges that lost uses during the current edit; checked by `finish`.
    pending: Vec<EdgeId>,
}

/// Result of cleaning one contour.
pub(crate) struct Cleaned {
    pub(crate) contour: Option<Vec<VertexId>>,
    pub(crate) bad_refs: usize,
    pub(crate) repeats: usize,
}

/// Drops vertex ids for which `ok` is false, removes consecutive repeats
/// (cyclically), and rejects a contour with fewer than 3 distinct vertices.
pub(crate) fn clean_contour(c: &[VertexId], ok: impl Fn(VertexId) -> bool) -> Cleaned {
    let mut bad_refs = 0;
    let mut repeats = 0;
    let mut out: Vec<VertexId> = Vec::with_capacity(c.len());
    for &v in c {
        if !ok(v) {
            bad_refs += 1;
            continue;
        }
        if out.last() == Some(&v) {
            repeats += 1;
            continue;
        }
        out.push(v);
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
        repeats += 1;
    }
    let mut distinct = out.clone();
    distinct.sort_unstable();
    distinct.dedup();
    Cleaned {
        contour: (distinct.len() >= 3).then_some(out),
        bad_refs,
        repeats,
    }
}

/// `base` if unused, else `base.2`, `base.3`, … (the first free one).
fn unique_name(set: &FxHashSet<String>, base: &str) -> String {
    if !set.contains(base) {
        return base.to_string();
    }
    (2u64..)
        .map(|k| format!("{base}.{k}"))
        .find(|c| !set.contains(c))
        .expect("some suffix is free")
}

#[inline]
fn edge_key(a: VertexId, b: VertexId) -> ((VertexId, VertexId), bool) {
    if a < b {
        ((a, b), true)
    } else {
        ((b, a), false)
    }
}

impl Mesh {
    // ------------------------------------------------------------------
    // Construction and conversion
    // ------------------------------------------------------------------

    /// Builds the topology of the top-level faces of `m`.
    ///
    /// A model with defs or instances is flattened first (default limits).
    /// Faces may have holes and islands; an edge may be shared by any number of
    /// faces, or by two contours of one face. Contours are cleaned where they
    /// would break the invariants (see [`Repair`] and [`Mesh::repairs`]):
    /// repeated consecutive vertices are removed, contours with fewer than
    /// three distinct vertices dropped, faces left without contours removed.
    ///
    /// # Panics
    /// When the model is not flat and flattening fails (it would exceed the
    /// default size limits); use [`Mesh::try_from_model`] to get the error.
    pub fn from_model(m: Model) -> Mesh {
        match Self::try_from_model(m) {
            Ok(mesh) => mesh,
            Err(d) => panic!("winged::Mesh::from_model: flattening failed: {}", d.message),
        }
    }

    /// As [`Mesh::from_model`], but returns the flattening error instead of panicking.
    pub fn try_from_model(m: Model) -> Result<Mesh, ug::Diagnostic> {
        let m = if m.is_flat() { m } else { m.flatten()? };
        Ok(Self::build(m))
    }

    fn build(mut model: Model) -> Mesh {
        let nv = model.vertices.len();
        let nf = model.faces.len();
        let mut order = Order::new(model.items.clone());
        let mut face_slot = vec![NIL; nf];
        let mut vertex_slot = vec![NIL; nv];
        let mut last_vertex_slot = NIL;
        let mut last_material_slot = NIL;
        let mut repairs = Vec::new();
        for (s, it) in order.iter() {
            match it {
                Item::Face(f) if f.idx() < nf => {
                    // A repeated or out-of-range statement keeps its slot but
                    // is skipped: only the slot in `face_slot` is output.
                    if face_slot[f.idx()] == NIL {
                        face_slot[f.idx()] = s;
                    } else {
                        repairs.push(Repair::RepeatedStatement { face: *f });
                    }
                }
                Item::Vertex(v) if v.idx() < nv => {
                    if vertex_slot[v.idx()] == NIL {
                        vertex_slot[v.idx()] = s;
                    }
                    last_vertex_slot = s;
                }
                Item::Material(_) => last_material_slot = s,
                _ => {}
            }
        }
        // Vertices without a statement get one after the last vertex.
        for (v, slot) in vertex_slot.iter_mut().enumerate() {
            if *slot == NIL {
                let s =
                    order.insert_directly_after(last_vertex_slot, Item::Vertex(VertexId(v as u32)));
                *slot = s;
                last_vertex_slot = s;
            }
        }
        let vertex_names = model.vertices.iter().map(|v| v.name.clone()).collect();
        let face_names = model
            .faces
            .iter()
            .filter_map(|f| f.name.clone())
            .chain(model.wires.iter().filter_map(|w| w.name.clone()))
            .collect();

        // Clean the contours of top-level faces; everything else is dead.
        let mut face_live = vec![false; nf];
        for (fi, face) in model.faces.iter_mut().enumerate() {
            let fid = FaceId(fi as u32);
            if face_slot[fi] == NIL {
                face.contours.clear();
                continue;
            }
            let mut kept = Vec::with_capacity(face.contours.len());
            for (ci, c) in face.contours.iter().enumerate() {
                let cl = clean_contour(c, |v| v.idx() < nv);
                if cl.bad_refs > 0 {
                    repairs.push(Repair::DroppedVertexRef {
                        face: fid,
                        contour: ci,
                    });
                }
                if cl.repeats > 0 {
                    repairs.push(Repair::RemovedRepeats {
                        face: fid,
                        contour: ci,
                        count: cl.repeats,
                    });
                }
                match cl.contour {
                    Some(c) => kept.push(c),
                    None => repairs.push(Repair::DroppedContour {
                        face: fid,
                        contour: ci,
                    }),
                }
            }
            if kept.is_empty() {
                repairs.push(Repair::DroppedFace { face: fid });
            } else {
                face_live[fi] = true;
            }
            face.contours = kept;
        }
        let live_faces = face_live.iter().filter(|&&l| l).count();
        let mut mesh = Mesh {
            model,
            face_live,
            contour_edges: vec![Vec::new(); nf],
            edges: Vec::new(),
            edge_map: FxHashMap::default(),
            vertex_edges: vec![Vec::new(); nv],
            vertex_live: vec![true; nv],
            order,
            face_slot,
            vertex_slot,
            last_vertex_slot,
            last_material_slot,
            vertex_names,
            face_names,
            repairs,
            live_faces,
            live_edges: 0,
            pending: Vec::new(),
        };
        for f in 0..nf {
            if mesh.face_live[f] {
                mesh.attach(FaceId(f as u32));
            }
        }
        mesh
    }

    /// The model's arenas: vertices (positions, names, colours), faces (a
    /// removed face has no contours), materials, wires.
    ///
    /// Its `items` are the statements as they were when the mesh was built;
    /// edits do not update them. Use [`Mesh::faces`] and [`Mesh::vertices`]
    /// for the live statement order and [`Mesh::to_model`] /
    /// [`Mesh::into_model`] for a model to write.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// What construction had to clean up (empty for a clean model).
    pub fn repairs(&self) -> &[Repair] {
        &self.repairs
    }

    /// Back to a model: names, materials, wires and other statements kept in
    /// place; removed faces (and removed vertices) dropped; edited faces in
    /// their place, new faces after their parent. Vertices and faces are
    /// renumbered in statement order (so an unedited mesh gives back the
    /// model it was built from, and the result equals what parsing its text gives).
    pub fn into_model(self) -> Model {
        self.to_model()
    }

    /// The current state as a model (see [`Mesh::into_model`]).
    pub fn to_model(&self) -> Model {
        let m = &self.model;
        let mut vmap = vec![u32::MAX; m.vertices.len()];
        let mut fmap = vec![u32::MAX; m.faces.len()];
        let mut nv = 0u32;
        let mut nf = 0u32;
        let mut items = Vec::with_capacity(self.order.len());
        for (s, it) in self.order.iter() {
            match *it {
                Item::Vertex(v) => {
                    if self.vertex_slot.get(v.idx()) == Some(&s) && self.vertex_live[v.idx()] {
                        vmap[v.idx()] = nv;
                        items.push(Item::Vertex(VertexId(nv)));
                        nv += 1;
                    }
                }
                Item::Face(f) => {
                    if self.face_slot.get(f.idx()) == Some(&s) && self.face_live[f.idx()] {
                        fmap[f.idx()] = nf;
                        items.push(Item::Face(FaceId(nf)));
                        nf += 1;
                    }
                }
                ref other => items.push(other.clone()),
            }
        }
        let mut vertices = vec![None; nv as usize];
        for (old, &new) in vmap.iter().enumerate() {
            if new != u32::MAX {
                vertices[new as usize] = Some(m.vertices[old].clone());
            }
        }
        let remap = |c: &Vec<VertexId>| -> Vec<VertexId> {
            c.iter().map(|v| VertexId(vmap[v.idx()])).collect()
        };
        let mut faces = vec![None; nf as usize];
        for (old, &new) in fmap.iter().enumerate() {
            if new != u32::MAX {
                let f = &m.faces[old];
                faces[new as usize] = Some(Face {
                    name: f.name.clone(),
                    contours: f.contours.iter().map(remap).collect(),
                    material: f.material,
                });
            }
        }
        let wires = m
            .wires
            .iter()
            .map(|w| ug::Wire {
                name: w.name.clone(),
                polylines: w
                    .polylines
                    .iter()
                    .map(|p| {
                        p.iter()
                            .filter(|v| vmap.get(v.idx()).is_some_and(|&n| n != u32::MAX))
                            .map(|v| VertexId(vmap[v.idx()]))
                            .collect()
                    })
                    .collect(),
                material: w.material,
            })
            .collect();
        Model {
            materials: m.materials.clone(),
            vertices: vertices.into_iter().map(|v| v.expect("mapped")).collect(),
            faces: faces.into_iter().map(|f| f.expect("mapped")).collect(),
            wires,
            defs: Vec::new(),
            instances: Vec::new(),
            items,
        }
    }

    // ------------------------------------------------------------------
    // Topology bookkeeping (all edits go detach → change contours → attach → finish)
    // ------------------------------------------------------------------

    /// Adds the edge uses of a live face's contours (creating edges as needed).
    pub(crate) fn attach(&mut self, f: FaceId) {
        let Mesh {
            model,
            contour_edges,
            edges,
            edge_map,
            vertex_edges,
            live_edges,
            ..
        } = self;
        let face = &model.faces[f.idx()];
        let mut ce = Vec::with_capacity(face.contours.len());
        for (ci, c) in face.contours.iter().enumerate() {
            let n = c.len();
            let mut row = Vec::with_capacity(n);
            for i in 0..n {
                let (key, forward) = edge_key(c[i], c[(i + 1) % n]);
                let e = *edge_map.entry(key).or_insert_with(|| {
                    let id = EdgeId(edges.len() as u32);
                    edges.push(Edge {
                        v: [key.0, key.1],
                        uses: Vec::new(),
                    });
                    for v in [key.0, key.1] {
                        let list = &mut vertex_edges[v.idx()];
                        let at = list.partition_point(|&x| x < id);
                        list.insert(at, id);
                    }
                    *live_edges += 1;
                    id
                });
                let u = EdgeUse {
                    face: f,
                    contour: ci as u32,
                    index: i as u32,
                    forward,
                };
                let uses = &mut edges[e.idx()].uses;
                let at = uses.partition_point(|x| *x < u);
                uses.insert(at, u);
                row.push(e);
            }
            ce.push(row);
        }
        contour_edges[f.idx()] = ce;
    }

    /// Removes the edge uses of a face; edges left without uses are collected
    /// for `finish` (so that an edge re-used by the same edit keeps its id).
    pub(crate) fn detach(&mut self, f: FaceId) {
        let ce = std::mem::take(&mut self.contour_edges[f.idx()]);
        let mut es: Vec<EdgeId> = ce.into_iter().flatten().collect();
        es.sort_unstable();
        es.dedup();
        for e in es {
            let uses = &mut self.edges[e.idx()].uses;
            uses.retain(|u| u.face != f);
            if uses.is_empty() {
                self.pending.push(e);
            }
        }
    }

    /// Tombstones the edges that an edit left without uses.
    pub(crate) fn finish(&mut self) {
        let pending = std::mem::take(&mut self.pending);
        for e in pending {
            let edge = &self.edges[e.idx()];
            if !edge.uses.is_empty() {
                continue;
            }
            let key = (edge.v[0], edge.v[1]);
            if self.edge_map.get(&key) != Some(&e) {
                continue; // already removed
            }
            self.edge_map.remove(&key);
            for v in [key.0, key.1] {
                let list = &mut self.vertex_edges[v.idx()];
                if let Ok(at) = list.binary_search(&e) {
                    list.remove(at);
                }
            }
            self.live_edges -= 1;
        }
    }

    /// Marks a detached face dead.
    pub(crate) fn kill_face(&mut self, f: FaceId) {
        if self.face_live[f.idx()] {
            self.face_live[f.idx()] = false;
            self.live_faces -= 1;
        }
        self.model.faces[f.idx()].contours.clear();
        self.contour_edges[f.idx()].clear();
    }

    fn vertex_ok(&self, v: VertexId) -> bool {
        v.idx() < self.vertex_live.len() && self.vertex_live[v.idx()]
    }

    /// Cleans contours for a live face: invalid vertices dropped, repeats
    /// removed, degenerate contours dropped.
    fn clean_contours(&self, contours: Vec<Vec<VertexId>>) -> Vec<Vec<VertexId>> {
        contours
            .iter()
            .filter_map(|c| clean_contour(c, |v| self.vertex_ok(v)).contour)
            .collect()
    }

    // ------------------------------------------------------------------
    // Queries
    // ------------------------------------------------------------------

    /// Live edges, ascending id.
    pub fn edges(&self) -> impl Iterator<Item = EdgeId> + '_ {
        self.edges
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_live())
            .map(|(i, _)| EdgeId(i as u32))
    }

    /// The edge (a removed edge has no uses).
    pub fn edge(&self, e: EdgeId) -> &Edge {
        &self.edges[e.idx()]
    }

    pub fn is_edge_live(&self, e: EdgeId) -> bool {
        self.edges.get(e.idx()).is_some_and(Edge::is_live)
    }

    /// Number of live edges.
    pub fn num_edges(&self) -> usize {
        self.live_edges
    }

    /// The live edge joining two vertices (either order).
    pub fn edge_between(&self, a: VertexId, b: VertexId) -> Option<EdgeId> {
        self.edge_map.get(&edge_key(a, b).0).copied()
    }

    /// Live edges at a vertex, ascending.
    pub fn vertex_edges(&self, v: VertexId) -> &[EdgeId] {
        self.vertex_edges.get(v.idx()).map_or(&[], |l| l.as_slice())
    }

    /// Faces that use a vertex, sorted, without repeats.
    pub fn vertex_faces(&self, v: VertexId) -> Vec<FaceId> {
        let mut fs: Vec<FaceId> = self
            .vertex_edges(v)
            .iter()
            .flat_map(|e| self.edges[e.idx()].uses.iter().map(|u| u.face))
            .collect();
        fs.sort_unstable();
        fs.dedup();
        fs
    }

    /// The face's edges in contour order, all contours (an edge walked twice appears twice).
    pub fn face_edges(&self, f: FaceId) -> Vec<EdgeId> {
        self.contour_edges
            .get(f.idx())
            .map_or_else(Vec::new, |cs| cs.iter().flatten().copied().collect())
    }

    /// The edges of one contour: element `i` joins vertex `i` to vertex `i+1`.
    pub fn contour_edges(&self, f: FaceId, contour: usize) -> &[EdgeId] {
        self.contour_edges
            .get(f.idx())
            .and_then(|cs| cs.get(contour))
            .map_or(&[], |c| c.as_slice())
    }

    /// Live faces in statement order.
    pub fn faces(&self) -> impl Iterator<Item = FaceId> + '_ {
        self.order.iter().filter_map(move |(s, it)| match *it {
            Item::Face(f) if self.face_slot.get(f.idx()) == Some(&s) && self.face_live[f.idx()] => {
                Some(f)
            }
            _ => None,
        })
    }

    /// Live vertices in statement order (used or not).
    pub fn vertices(&self) -> impl Iterator<Item = VertexId> + '_ {
        self.order.iter().filter_map(move |(s, it)| match *it {
            Item::Vertex(v)
                if self.vertex_slot.get(v.idx()) == Some(&s) && self.vertex_live[v.idx()] =>
            {
                Some(v)
            }
            _ => None,
        })
    }

    /// Number of live faces.
    pub fn num_faces(&self) -> usize {
        self.live_faces
    }

    pub fn is_face_live(&self, f: FaceId) -> bool {
        self.face_live.get(f.idx()).copied().unwrap_or(false)
    }

    pub fn is_vertex_live(&self, v: VertexId) -> bool {
        self.vertex_ok(v)
    }

    /// The face record (name, contours, material); a removed face has no contours.
    pub fn face(&self, f: FaceId) -> &Face {
        &self.model.faces[f.idx()]
    }

    /// A vertex's position.
    pub fn pos(&self, v: VertexId) -> DVec3 {
        self.model.vertices[v.idx()].pos
    }

    /// Faces sharing an edge with `f` (not `f` itself), sorted, without repeats.
    pub fn face_neighbors(&self, f: FaceId) -> Vec<FaceId> {
        let mut es = self.face_edges(f);
        es.sort_unstable();
        es.dedup();
        let mut fs: Vec<FaceId> = es
            .iter()
            .flat_map(|e| self.edges[e.idx()].uses.iter().map(|u| u.face))
            .filter(|&g| g != f)
            .collect();
        fs.sort_unstable();
        fs.dedup();
        fs
    }

    /// Exactly one use.
    pub fn is_boundary(&self, e: EdgeId) -> bool {
        self.edges[e.idx()].uses.len() == 1
    }

    /// Exactly two uses.
    pub fn is_manifold(&self, e: EdgeId) -> bool {
        self.edges[e.idx()].uses.len() == 2
    }

    /// Exactly two uses, walking the edge in opposite directions.
    pub fn consistently_oriented(&self, e: EdgeId) -> bool {
        let u = &self.edges[e.idx()].uses;
        u.len() == 2 && u[0].forward != u[1].forward
    }

    /// Best-fit plane of the outer contour (Newell normal through the
    /// centroid); `None` for a removed face or one without area.
    pub fn face_plane(&self, f: FaceId) -> Option<Plane> {
        let outer = self.model.faces.get(f.idx())?.contours.first()?;
        let pts: Vec<DVec3> = outer.iter().map(|&v| self.pos(v)).collect();
        Plane::fit(&pts)
    }

    /// Unit normal (Newell, outer contour), `None` when degenerate or removed.
    pub fn face_normal(&self, f: FaceId) -> Option<DVec3> {
        geom::face_normal(&self.face_points(f))
    }

    /// Signed area with holes and islands, along the outer contour's normal
    /// (holes subtract, islands add); 0 for a removed face.
    pub fn face_area(&self, f: FaceId) -> f64 {
        geom::face_area(&self.face_points(f))
    }

    /// The contours as positions.
    pub fn face_points(&self, f: FaceId) -> Vec<Vec<DVec3>> {
        self.model.faces.get(f.idx()).map_or_else(Vec::new, |face| {
            face.contours
                .iter()
                .map(|c| c.iter().map(|&v| self.pos(v)).collect())
                .collect()
        })
    }

    /// The end points' positions.
    pub fn edge_points(&self, e: EdgeId) -> [DVec3; 2] {
        let [a, b] = self.edges[e.idx()].v;
        [self.pos(a), self.pos(b)]
    }

    pub fn edge_length(&self, e: EdgeId) -> f64 {
        let [a, b] = self.edge_points(e);
        a.distance(b)
    }

    /// Whether a name is taken by a vertex (including removed ones).
    pub fn has_vertex_name(&self, name: &str) -> bool {
        self.vertex_names.contains(name)
    }

    /// Whether a name is taken by a face or a wire (they share names).
    pub fn has_face_name(&self, name: &str) -> bool {
        self.face_names.contains(name)
    }

    /// `base` if no vertex has it, else the first free `base.2`, `base.3`, …
    pub fn unique_vertex_name(&self, base: &str) -> String {
        unique_name(&self.vertex_names, base)
    }

    /// `base` if no face or wire has it, else the first free `base.2`, `base.3`, …
    /// (children of `wall3` become `wall3.2`, `wall3.3`, …).
    pub fn unique_face_name(&self, base: &str) -> String {
        unique_name(&self.face_names, base)
    }

    // ------------------------------------------------------------------
    // Edits
    // ------------------------------------------------------------------

    /// Inserts vertex `v` into edge `e` in every contour that walks it
    /// (T-vertex removal, stitching). Returns the two new edges: the one at
    /// `e.v[0]`, then the one at `e.v[1]` (existing edges when they were
    /// there already); `e` is removed, other edges keep their ids. Contours
    /// that already hold `v` elsewhere get it once more (they touch
    /// themselves there).
    ///
    /// # Panics
    /// When `e` is not a live edge, `v` is not a live vertex, or `v` is an end of `e`.
    pub fn split_edge(&mut self, e: EdgeId, v: VertexId) -> [EdgeId; 2] {
        assert!(self.is_edge_live(e), "split_edge: edge {} is not live", e.0);
        assert!(self.vertex_ok(v), "split_edge: vertex {} is not live", v.0);
        let [p, q] = self.edges[e.idx()].v;
        assert!(
            v != p && v != q,
            "split_edge: vertex {} is an end of edge {}",
            v.0,
            e.0
        );
        let uses = self.edges[e.idx()].uses.clone();
        let faces = self.edges[e.idx()].faces();
        for &f in &faces {
            self.detach(f);
        }
        // Descending (face, contour, index): insertions do not move the
        // positions still to be processed.
        for u in uses.iter().rev() {
            let c = &mut self.model.faces[u.face.idx()].contours[u.contour as usize];
            c.insert(u.index as usize + 1, v);
        }
        for &f in &faces {
            self.attach(f);
        }
        self.finish();
        [
            self.edge_between(p, v).expect("split edge exists"),
            self.edge_between(v, q).expect("split edge exists"),
        ]
    }

    /// Adds a vertex statement after the last vertex statement. `None` gives
    /// a derived name (`v<id>`); a name that is taken gets a `.2`, `.3`, …
    /// suffix, so names never collide.
    pub fn add_vertex(&mut self, name: Option<&str>, p: DVec3) -> VertexId {
        let id = VertexId(self.model.vertices.len() as u32);
        let base = match name {
            Some(n) => n.to_string(),
            None => format!("v{}", id.0),
        };
        let name = unique_name(&self.vertex_names, &base);
        self.vertex_names.insert(name.clone());
        self.model.vertices.push(Vertex {
            name,
            pos: p,
            color: None,
        });
        self.vertex_live.push(true);
        self.vertex_edges.push(Vec::new());
        let s = self
            .order
            .insert_directly_after(self.last_vertex_slot, Item::Vertex(id));
        self.last_vertex_slot = s;
        self.vertex_slot.push(s);
        id
    }

    /// Moves a vertex (topology is unchanged).
    pub fn set_vertex_pos(&mut self, v: VertexId, p: DVec3) {
        self.model.vertices[v.idx()].pos = p;
    }

    /// Sets a vertex's colour (`None`: no colour).
    pub fn set_vertex_color(&mut self, v: VertexId, c: Option<MaterialId>) {
        self.model.vertices[v.idx()].color = c;
    }

    /// Removes a vertex that no live face and no wire uses; returns whether it did.
    pub fn remove_vertex(&mut self, v: VertexId) -> bool {
        if !self.vertex_ok(v) || !self.vertex_edges[v.idx()].is_empty() {
            return false;
        }
        let in_wire = self
            .model
            .wires
            .iter()
            .any(|w| w.polylines.iter().any(|p| p.contains(&v)));
        if in_wire {
            return false;
        }
        self.vertex_live[v.idx()] = false;
        true
    }

    /// Adds a material statement after the last material statement (at the
    /// front when there is none). A taken name is not changed; keep names unique.
    pub fn add_material(&mut self, m: Material) -> MaterialId {
        let id = MaterialId(self.model.materials.len() as u32);
        self.model.materials.push(m);
        let s = self
            .order
            .insert_directly_after(self.last_material_slot, Item::Material(id));
        self.last_material_slot = s;
        id
    }

    /// Sets a face's material.
    pub fn set_face_material(&mut self, f: FaceId, m: Option<MaterialId>) {
        self.model.faces[f.idx()].material = m;
    }

    /// Merges `b` into `a` across all their shared edges (the grouper): the
    /// shared edges disappear and the remaining boundary is traced into
    /// closed contours. The result may gain holes (a ring of faces around a
    /// window) or lose contours (a face filling a hole). It keeps `a`'s id,
    /// name, material and place; `b` is removed.
    ///
    /// `b` is taken with `a`'s orientation: when most shared edges are walked
    /// the same way by both, `b` is reversed first. Where the boundary touches
    /// itself at a vertex, it is split there into separate contours (the
    /// tracing turns as far left as possible, so contours never cross). The
    /// contour with the largest area wound like `a`'s outer contour becomes
    /// contour 0; the others follow in the order of their first edge in `a`
    /// then `b`. Turns are measured in the plane of `a`'s outer contour, so
    /// the faces should be (nearly) coplanar for the result to be planar;
    /// the topology is valid in any case.
    pub fn merge_faces(&mut self, a: FaceId, b: FaceId) -> Result<FaceId, MergeError> {
        crate::merge::merge(self, a, b)
    }

    /// Removes a face (its edges lose their uses; edges left unused are removed).
    /// Nothing happens for a face that is already removed.
    pub fn remove_face(&mut self, f: FaceId) {
        if !self.is_face_live(f) {
            return;
        }
        self.detach(f);
        self.kill_face(f);
        self.finish();
    }

    /// Reverses every contour, keeping each contour's first vertex first.
    pub fn flip_face(&mut self, f: FaceId) {
        if !self.is_face_live(f) {
            return;
        }
        self.detach(f);
        for c in &mut self.model.faces[f.idx()].contours {
            c[1..].reverse();
        }
        self.attach(f);
        self.finish();
    }

    /// Replaces a face's contours (re-planing: a tool that moved or chose new
    /// vertices for a face), updating the topology. Contours are cleaned like
    /// [`Mesh::from_model`] does (dead vertex ids dropped, repeats removed,
    /// contours with < 3 distinct vertices dropped); if none is left the face
    /// is removed. Returns whether the face is still live.
    pub fn set_face_contours(&mut self, f: FaceId, contours: Vec<Vec<VertexId>>) -> bool {
        if !self.is_face_live(f) {
            return false;
        }
        let contours = self.clean_contours(contours);
        self.detach(f);
        if contours.is_empty() {
            self.kill_face(f);
        } else {
            self.model.faces[f.idx()].contours = contours;
            self.attach(f);
        }
        self.finish();
        self.is_face_live(f)
    }

    /// The same as [`Mesh::set_face_contours`].
    pub fn replan_face(&mut self, f: FaceId, contours: Vec<Vec<VertexId>>) -> bool {
        self.set_face_contours(f, contours)
    }

    /// Replaces `old` by `new` in every face contour and wire. Consecutive
    /// repeats that this creates are removed; a hole or island left with
    /// fewer than 3 distinct vertices is dropped; a face whose outer contour
    /// is left so is removed. Returns the removed faces, ascending. `old` stays
    /// in the model, unused (see [`Mesh::remove_vertex`]).
    pub fn replace_vertex(&mut self, old: VertexId, new: VertexId) -> Vec<FaceId> {
        if old == new || !self.vertex_ok(old) || !self.vertex_ok(new) {
            return Vec::new();
        }
        let faces = self.vertex_faces(old);
        let mut removed = Vec::new();
        for &f in &faces {
            self.detach(f);
            let contours = std::mem::take(&mut self.model.faces[f.idx()].contours);
            let mut kept = Vec::with_capacity(contours.len());
            let mut outer_gone = false;
            for (ci, mut c) in contours.into_iter().enumerate() {
                for v in &mut c {
                    if *v == old {
                        *v = new;
                    }
                }
                match clean_contour(&c, |_| true).contour {
                    Some(c) => kept.push(c),
                    None if ci == 0 => outer_gone = true,
                    None => {}
                }
            }
            if outer_gone {
                self.kill_face(f);
                removed.push(f);
            } else {
                self.model.faces[f.idx()].contours = kept;
                self.attach(f);
            }
        }
        self.finish();
        for w in &mut self.model.wires {
            for p in &mut w.polylines {
                if p.contains(&old) {
                    for v in p.iter_mut() {
                        if *v == old {
                            *v = new;
                        }
                    }
                    p.dedup();
                }
            }
        }
        removed
    }

    /// Adds a face, placed in statement order after `after` (after its
    /// earlier children, so children keep their creation order) or at the end.
    /// `after` may be a removed face: the new face takes its place.
    /// The contours are cleaned as [`Mesh::set_face_contours`] does; a face
    /// left with none is created removed (check [`Mesh::is_face_live`]).
    /// A name that is taken gets a `.2`, `.3`, … suffix.
    pub fn add_face(&mut self, after: Option<FaceId>, face: Face) -> FaceId {
        let id = FaceId(self.model.faces.len() as u32);
        let contours = self.clean_contours(face.contours);
        let name = face.name.map(|n| {
            let n = unique_name(&self.face_names, &n);
            self.face_names.insert(n.clone());
            n
        });
        let live = !contours.is_empty();
        self.model.faces.push(Face {
            name,
            contours,
            material: face.material,
        });
        self.contour_edges.push(Vec::new());
        self.face_live.push(live);
        let parent = after
            .and_then(|a| self.face_slot.get(a.idx()).copied())
            .filter(|&s| s != NIL);
        let s = match parent {
            Some(ps) => self.order.insert_child(ps, Item::Face(id)),
            None => self.order.push_back(Item::Face(id)),
        };
        self.face_slot.push(s);
        if live {
            self.live_faces += 1;
            self.attach(id);
        }
        id
    }
}
