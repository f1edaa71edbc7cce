//! The model as GPU vertex data: triangles with per-vertex colours (lit
//! models) or material colours (unlit), face normals for flat shading, and
//! the face edges for the `--mesh` overlay.

use glam::DVec3;
use ug::Model;

/// One vertex as the shader reads it (`view.wgsl`, `VIn`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuVertex {
    /// Position relative to [`Scene::origin`].
    pub pos: [f32; 3],
    /// Lit: radiance B/π (linear, model units); unlit: display colour in 0..1.
    pub colour: [f32; 3],
    /// The face's unit normal (front side).
    pub normal: [f32; 3],
}

/// What [`Scene::from_model`] built.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub vertices: Vec<GpuVertex>,
    /// Triangle list into `vertices`, counter-clockwise seen from the front.
    pub triangles: Vec<u32>,
    /// Line list into `vertices`: every face contour's edges.
    pub lines: Vec<u32>,
    /// True when the model carries per-vertex colours (ugrad output).
    pub lit: bool,
    /// Model-space origin subtracted from positions (the bounds' centre).
    pub origin: DVec3,
    pub bounds: Option<crate::camera::Bounds>,
    /// Faces skipped because they are degenerate or cannot be triangulated.
    pub skipped: usize,
    /// Faces of a lit model without vertex colours (drawn with their emission).
    pub unlit_in_lit: usize,
    /// Largest colour value (to scale into the half-float target's range).
    pub max_colour: f32,
}

/// Area-weighted RGB → luminance (Rec. 709 / sRGB primaries).
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

impl Scene {
    /// Builds the scene from a flat model (`Model::flatten` first).
    pub fn from_model(m: &Model) -> Scene {
        let lit = m.vertices.iter().any(|v| v.color.is_some());
        let bounds = crate::camera::Bounds::of(
            m.faces
                .iter()
                .flat_map(|f| f.contours.iter().flatten())
                .map(|v| m.vertices[v.idx()].pos),
        );
        let origin = bounds.map(|b| b.centre()).unwrap_or_default();
        let mut s = Scene {
            lit,
            origin,
            bounds,
            ..Default::default()
        };
        let rel = |p: DVec3| (p - origin).as_vec3().to_array();
        for f in &m.faces {
            let pts: Vec<Vec<DVec3>> = f
                .contours
                .iter()
                .map(|c| c.iter().map(|v| m.vertices[v.idx()].pos).collect())
                .collect();
            let outer = &pts[0];
            let n = geom::plane::newell_normal(outer);
            if !n.is_finite() || n.length() <= 0.0 {
                s.skipped += 1;
                continue;
            }
            let n = n.normalize();
            let tris: Vec<[usize; 3]> = if pts.len() == 1 && is_convex(outer, n) {
                (1..outer.len() - 1).map(|i| [0, i, i + 1]).collect()
            } else {
                match geom::triangulate::fold_triangles(&pts) {
                    Some(t) => t,
                    None => {
                        s.skipped += 1;
                        continue;
                    }
                }
            };
            let mat = f.material.map(|id| &m.materials[id.idx()]);
            let (diffuse, emission) = match mat {
                Some(mat) => (mat.diffuse(), mat.emission()),
                None => ([0.8; 3], [0.0; 3]),
            };
            let ids: Vec<ug::VertexId> = f.contours.iter().flatten().copied().collect();
            let all_coloured = ids.iter().all(|v| m.vertices[v.idx()].color.is_some());
            if lit && !all_coloured {
                s.unlit_in_lit += 1;
            }
            let colour_of = |v: ug::VertexId| -> [f32; 3] {
                let c = if lit {
                    match m.vertices[v.idx()].color {
                        Some(cid) if all_coloured => m.materials[cid.idx()].diffuse(),
                        _ => emission,
                    }
                    .map(|x| x / std::f64::consts::PI)
                } else if emission.iter().any(|&e| e > 0.0) {
                    let mx = emission.iter().cloned().fold(0.0, f64::max);
                    emission.map(|e| e / mx)
                } else {
                    diffuse
                };
                c.map(|x| {
                    if x.is_finite() {
                        x.max(0.0) as f32
                    } else {
                        0.0
                    }
                })
            };
            let base = s.vertices.len() as u32;
            let normal = n.as_vec3().to_array();
            for &v in &ids {
                let colour = colour_of(v);
                s.max_colour = colour.iter().cloned().fold(s.max_colour, f32::max);
                s.vertices.push(GpuVertex {
                    pos: rel(m.vertices[v.idx()].pos),
                    colour,
                    normal,
                });
            }
            let all: Vec<DVec3> = pts.iter().flatten().copied().collect();
            for t in tris {
                // Keep the face's orientation whatever the triangulator did.
                let tn = (all[t[1]] - all[t[0]]).cross(all[t[2]] - all[t[0]]);
                let t = if tn.dot(n) < 0.0 {
                    [t[0], t[2], t[1]]
                } else {
                    t
                };
                s.triangles.extend(t.map(|i| base + i as u32));
            }
            let mut k = base;
            for c in &f.contours {
                let len = c.len() as u32;
                for i in 0..len {
                    s.lines.push(k + i);
                    s.lines.push(k + (i + 1) % len);
                }
                k += len;
            }
        }
        s
    }
}

/// Strictly convex (every turn to the left of n, no collinear corners).
fn is_convex(p: &[DVec3], n: DVec3) -> bool {
    let k = p.len();
    k >= 3
        && (0..k).all(|i| {
            let a = p[i];
            let b = p[(i + 1) % k];
            let c = p[(i + 2) % k];
            (b - a).cross(c - b).dot(n) > 0.0
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Model {
        ug::parse(s.as_bytes(), "t.ug")
            .unwrap()
            .model
            .flatten()
            .unwrap()
    }

    #[test]
    fn unlit_quads_and_a_face_with_a_hole() {
        let m = parse(
            "c_rgb grey 0.5 0.5 0.5;
             v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;
             v e 1 1 0; v f 1 3 0; v g 3 3 0; v h 3 1 0;
             f frame (a b c d) (e f g h) grey;
             v p 0 0 1; v q 1 0 1; v r 1 1 1; v s 0 1 1;
             f quad (p q r s);",
        );
        let s = Scene::from_model(&m);
        assert!(!s.lit);
        assert_eq!(s.skipped, 0);
        // A square with a square hole: 8 triangles; the quad: 2.
        assert_eq!(s.triangles.len() / 3, 10);
        assert_eq!(s.lines.len() / 2, 12);
        // Every triangle faces +z like its face, and the area is kept.
        let mut area = 0.0f64;
        for t in s.triangles.chunks(3) {
            let p = [t[0], t[1], t[2]].map(|i| glam::Vec3::from(s.vertices[i as usize].pos));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(n.z > 0.0);
            area += n.length() as f64 / 2.0;
        }
        assert!((area - (16.0 - 4.0 + 1.0)).abs() < 1e-5, "{area}");
        assert_eq!(s.vertices[0].colour, [0.5; 3]);
        // No material: light grey.
        assert_eq!(s.vertices.last().unwrap().colour, [0.8; 3]);
    }

    #[test]
    fn lit_vertices_carry_radiance() {
        let m = parse(
            "c_rgb w 0.5 0.5 0.5;
             c_rgb b0 3.14159265358979 0 0; c_rgb b1 0 6.28318530717959 0;
             v a 0 0 0 b0; v b 1 0 0 b1; v c 1 1 0 b1; v d 0 1 0 b0;
             f q (a b c d) w;",
        );
        let s = Scene::from_model(&m);
        assert!(s.lit);
        assert!((s.vertices[0].colour[0] - 1.0).abs() < 1e-6);
        assert!((s.vertices[1].colour[1] - 2.0).abs() < 1e-6);
        assert!((s.max_colour - 2.0).abs() < 1e-6);
        assert_eq!(s.unlit_in_lit, 0);
    }
}
