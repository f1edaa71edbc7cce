//! Triangulation of planar polygons with holes: a constrained Delaunay
//! triangulation (spade) of the contour points with every contour edge as a
//! constraint, keeping the triangles inside the polygon (even-odd rule).

use glam::{DVec2, DVec3};
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use crate::polygon::{Location, locate_2d};

/// Triangulates a polygon given as 2-D contours (outer first, then holes and
/// islands). Returns triangles as indices into the contours' points numbered
/// contour after contour, counter-clockwise in 2-D.
///
/// Uses only the input points (no Steiner points). Returns `None` when the
/// contours cannot be triangulated as given: two points coincide, contour
/// edges cross, or a coordinate is not finite.
pub fn triangulate_polygon(contours: &[Vec<DVec2>]) -> Option<Vec<[usize; 3]>> {
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::new();
    let total: usize = contours.iter().map(Vec::len).sum();
    let mut handles = Vec::with_capacity(total);
    // Map from spade's vertex index back to ours.
    let mut back: Vec<usize> = Vec::with_capacity(total);
    for p in contours.iter().flatten() {
        let h = cdt.insert(Point2::new(p.x, p.y)).ok()?;
        if h.index() != back.len() {
            return None; // a duplicate point merged with an earlier one
        }
        back.push(handles.len());
        handles.push(h);
    }
    let mut base = 0;
    for c in contours {
        let n = c.len();
        for i in 0..n {
            let (a, b) = (handles[base + i], handles[base + (i + 1) % n]);
            if a == b {
                return None;
            }
            if !cdt.can_add_constraint(a, b) {
                return None;
            }
            cdt.add_constraint(a, b);
        }
        base += n;
    }
    if cdt.num_vertices() != total {
        return None;
    }
    let mut tris = Vec::new();
    for f in cdt.inner_faces() {
        let vs = f.vertices();
        let idx = vs.map(|v| back[v.fix().index()]);
        let pts = vs.map(|v| DVec2::new(v.position().x, v.position().y));
        let centroid = (pts[0] + pts[1] + pts[2]) / 3.0;
        if locate_2d(centroid, contours) == Location::Inside {
            tris.push(idx);
        }
    }
    Some(tris)
}

/// Triangles for a (possibly non-planar) face, as indices into its points
/// numbered contour after contour, wound like the face:
///
/// * a lone quadrilateral is split along the diagonal that folds it least
///   (the smaller angle between the two triangles' normals), never along a
///   diagonal that lies outside it;
/// * anything else gets the constrained Delaunay triangulation of its
///   contours projected on the plane of its outer contour's Newell normal.
///
/// `None` for a degenerate face or one whose projection crosses itself.
/// `ugplanar` tessellates with this, and `ugcheck` measures the area of
/// non-planar faces as the area of these triangles, so the two agree.
pub fn fold_triangles(contours: &[Vec<DVec3>]) -> Option<Vec<[usize; 3]>> {
    let n = crate::polygon::face_normal(contours)?;
    if contours.len() == 1 && contours[0].len() == 4 {
        let q = &contours[0];
        let options = [[[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]];
        let normal = |t: &[usize; 3]| (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]);
        let mut best: Option<(f64, usize)> = None;
        for (k, tris) in options.iter().enumerate() {
            let (n0, n1) = (normal(&tris[0]), normal(&tris[1]));
            if n0.dot(n) <= 0.0 || n1.dot(n) <= 0.0 {
                continue;
            }
            let fold = n0.normalize().dot(n1.normalize()).clamp(-1.0, 1.0).acos();
            if best.is_none_or(|(b, _)| fold < b) {
                best = Some((fold, k));
            }
        }
        if let Some((_, k)) = best {
            return Some(options[k].to_vec());
        }
    }
    let frame = crate::plane::Frame::new(contours[0][0], n);
    let c2: Vec<Vec<DVec2>> = contours
        .iter()
        .map(|c| c.iter().map(|&p| frame.to_2d(p)).collect())
        .collect();
    triangulate_polygon(&c2)
}

/// Sum of the 3-D areas of triangles given as indices into `pts`.
pub fn triangles_area(pts: &[DVec3], tris: &[[usize; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            (pts[t[1]] - pts[t[0]])
                .cross(pts[t[2]] - pts[t[0]])
                .length()
                / 2.0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polygon::signed_area_2d;

    fn area(contours: &[Vec<DVec2>], tris: &[[usize; 3]]) -> f64 {
        let pts: Vec<DVec2> = contours.iter().flatten().copied().collect();
        tris.iter()
            .map(|t| signed_area_2d(&[pts[t[0]], pts[t[1]], pts[t[2]]]))
            .sum()
    }

    #[test]
    fn square_with_hole() {
        let outer = vec![
            DVec2::new(0., 0.),
            DVec2::new(4., 0.),
            DVec2::new(4., 4.),
            DVec2::new(0., 4.),
        ];
        let hole = vec![
            DVec2::new(1., 1.),
            DVec2::new(1., 3.),
            DVec2::new(3., 3.),
            DVec2::new(3., 1.),
        ];
        let c = vec![outer, hole];
        let t = triangulate_polygon(&c).unwrap();
        assert_eq!(t.len(), 8);
        assert!((area(&c, &t) - 12.0).abs() < 1e-12);
        let pts: Vec<DVec2> = c.iter().flatten().copied().collect();
        assert!(
            t.iter()
                .all(|t| signed_area_2d(&[pts[t[0]], pts[t[1]], pts[t[2]]]) > 0.0)
        );
    }

    #[test]
    fn concave_l_shape() {
        let c = vec![vec![
            DVec2::new(0., 0.),
            DVec2::new(2., 0.),
            DVec2::new(2., 1.),
            DVec2::new(1., 1.),
            DVec2::new(1., 2.),
            DVec2::new(0., 2.),
        ]];
        let t = triangulate_polygon(&c).unwrap();
        assert_eq!(t.len(), 4);
        assert!((area(&c, &t) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_crossing_or_duplicate_points() {
        let bow = vec![vec![
            DVec2::new(0., 0.),
            DVec2::new(1., 1.),
            DVec2::new(1., 0.),
            DVec2::new(0., 1.),
        ]];
        assert!(triangulate_polygon(&bow).is_none());
        let dup = vec![vec![
            DVec2::new(0., 0.),
            DVec2::new(1., 0.),
            DVec2::new(1., 0.),
            DVec2::new(0., 1.),
        ]];
        assert!(triangulate_polygon(&dup).is_none());
    }
}
