//! The full consistency check.

use ug::{FaceId, Item, VertexId};

use crate::mesh::Mesh;
use crate::{EdgeId, EdgeUse};

impl Mesh {
    /// Checks every invariant of the topology:
    /// - every live face has at least one contour; every contour has at least
    ///   3 distinct vertices, no vertex followed by itself (no zero-length
    ///   edge), and only live vertex ids;
    /// - every contour position names the live edge between its vertex and
    ///   the next, and that edge has exactly one use for the position, with
    ///   the right direction; every use of every edge is such a position;
    /// - edges: `v[0] < v[1]`, uses sorted without repeats, the edge lookup
    ///   finds exactly the live edges; removed edges have no uses;
    /// - each vertex's edge list is exactly its live edges, ascending;
    /// - removed faces have no contours and no edges; the statement list is
    ///   linked and holds each face and vertex once; the counters agree.
    pub fn validate(&self) -> Result<(), String> {
        let nv = self.model.vertices.len();
        let nf = self.model.faces.len();
        let ne = self.edges.len();
        if self.face_live.len() != nf
            || self.contour_edges.len() != nf
            || self.face_slot.len() != nf
            || self.vertex_live.len() != nv
            || self.vertex_edges.len() != nv
            || self.vertex_slot.len() != nv
        {
            return Err("arena sizes disagree".into());
        }

        // Faces → edges.
        let mut total_positions = 0usize;
        let mut live_faces = 0usize;
        for fi in 0..nf {
            let f = FaceId(fi as u32);
            let face = &self.model.faces[fi];
            let ce = &self.contour_edges[fi];
            if !self.face_live[fi] {
                if !face.contours.is_empty() || !ce.is_empty() {
                    return Err(format!("removed face {fi} still has contours or edges"));
                }
                continue;
            }
            live_faces += 1;
            if face.contours.is_empty() {
                return Err(format!("face {fi} has no contour"));
            }
            if ce.len() != face.contours.len() {
                return Err(format!(
                    "face {fi}: contour edge lists do not match contours"
                ));
            }
            for (ci, c) in face.contours.iter().enumerate() {
                let n = c.len();
                let mut distinct = c.clone();
                distinct.sort_unstable();
                distinct.dedup();
                if distinct.len() < 3 {
                    return Err(format!(
                        "face {fi} contour {ci} has {} distinct vertices",
                        distinct.len()
                    ));
                }
                if ce[ci].len() != n {
                    return Err(format!(
                        "face {fi} contour {ci}: edge list length {} != {n}",
                        ce[ci].len()
                    ));
                }
                for i in 0..n {
                    let (a, b) = (c[i], c[(i + 1) % n]);
                    for v in [a, b] {
                        if v.idx() >= nv || !self.vertex_live[v.idx()] {
                            return Err(format!(
                                "face {fi} contour {ci} names dead vertex {}",
                                v.0
                            ));
                        }
                    }
                    if a == b {
                        return Err(format!(
                            "face {fi} contour {ci} has a zero-length edge at position {i}"
                        ));
                    }
                    let e = ce[ci][i];
                    if e.idx() >= ne {
                        return Err(format!(
                            "face {fi} contour {ci} position {i}: edge {} out of range",
                            e.0
                        ));
                    }
                    let edge = &self.edges[e.idx()];
                    let forward = a < b;
                    let want = if forward { [a, b] } else { [b, a] };
                    if edge.v != want {
                        return Err(format!(
                            "face {fi} contour {ci} position {i}: edge {} joins {:?}, not {:?}",
                            e.0, edge.v, want
                        ));
                    }
                    let u = EdgeUse {
                        face: f,
                        contour: ci as u32,
                        index: i as u32,
                        forward,
                    };
                    let hits = edge.uses.iter().filter(|x| **x == u).count();
                    if hits != 1 {
                        return Err(format!(
                            "face {fi} contour {ci} position {i}: edge {} has {hits} matching uses",
                            e.0
                        ));
                    }
                    total_positions += 1;
                }
            }
        }
        if live_faces != self.live_faces {
            return Err(format!(
                "{live_faces} live faces, counter says {}",
                self.live_faces
            ));
        }

        // Edges → uses.
        let mut total_uses = 0usize;
        let mut live_edges = 0usize;
        for (ei, edge) in self.edges.iter().enumerate() {
            let e = EdgeId(ei as u32);
            let key = (edge.v[0], edge.v[1]);
            if edge.uses.is_empty() {
                if self.edge_map.get(&key) == Some(&e) {
                    return Err(format!("removed edge {ei} is still in the lookup"));
                }
                for v in edge.v {
                    if v.idx() < nv && self.vertex_edges[v.idx()].binary_search(&e).is_ok() {
                        return Err(format!(
                            "removed edge {ei} is still listed at vertex {}",
                            v.0
                        ));
                    }
                }
                continue;
            }
            live_edges += 1;
            if edge.v[0] >= edge.v[1] {
                return Err(format!(
                    "edge {ei}: v[0] {} is not < v[1] {}",
                    edge.v[0].0, edge.v[1].0
                ));
            }
            if self.edge_map.get(&key) != Some(&e) {
                return Err(format!("edge {ei} is not found by its end points"));
            }
            if !edge.uses.windows(2).all(|w| w[0] < w[1]) {
                return Err(format!("edge {ei}: uses not sorted or repeated"));
            }
            for u in &edge.uses {
                let ok = self.face_live.get(u.face.idx()).copied().unwrap_or(false)
                    && self.contour_edges[u.face.idx()]
                        .get(u.contour as usize)
                        .and_then(|c| c.get(u.index as usize))
                        == Some(&e);
                if !ok {
                    return Err(format!(
                        "edge {ei}: use {u:?} is not a position of a live face walking it"
                    ));
                }
                let c = &self.model.faces[u.face.idx()].contours[u.contour as usize];
                let a = c[u.index as usize];
                if (a == edge.v[0]) != u.forward {
                    return Err(format!("edge {ei}: use {u:?} has the wrong direction"));
                }
            }
            total_uses += edge.uses.len();
            for v in edge.v {
                if self.vertex_edges[v.idx()].binary_search(&e).is_err() {
                    return Err(format!("edge {ei} is not listed at its vertex {}", v.0));
                }
            }
        }
        if total_uses != total_positions {
            return Err(format!(
                "{total_uses} edge uses for {total_positions} contour positions"
            ));
        }
        if live_edges != self.live_edges || self.edge_map.len() != live_edges {
            return Err(format!(
                "{live_edges} live edges, counter {} and lookup {}",
                self.live_edges,
                self.edge_map.len()
            ));
        }

        // Vertices → edges.
        for (vi, list) in self.vertex_edges.iter().enumerate() {
            if !list.windows(2).all(|w| w[0] < w[1]) {
                return Err(format!("vertex {vi}: edge list not ascending"));
            }
            for e in list {
                let edge = self
                    .edges
                    .get(e.idx())
                    .ok_or(format!("vertex {vi}: edge {} out of range", e.0))?;
                if edge.uses.is_empty() || !edge.v.contains(&VertexId(vi as u32)) {
                    return Err(format!(
                        "vertex {vi}: lists edge {} that is dead or not at it",
                        e.0
                    ));
                }
            }
            if !self.vertex_live[vi] && !list.is_empty() {
                return Err(format!("removed vertex {vi} still has edges"));
            }
        }

        // Statement order.
        self.order.check()?;
        for (fi, &s) in self.face_slot.iter().enumerate() {
            if s == crate::order::NIL && !self.face_live[fi] {
                continue; // never a top-level face
            }
            if (s as usize) >= self.order.len()
                || *self.order.item(s) != Item::Face(FaceId(fi as u32))
            {
                return Err(format!("face {fi} has no statement"));
            }
        }
        for (vi, &s) in self.vertex_slot.iter().enumerate() {
            if (s as usize) >= self.order.len()
                || *self.order.item(s) != Item::Vertex(VertexId(vi as u32))
            {
                return Err(format!("vertex {vi} has no statement"));
            }
        }
        Ok(())
    }
}
