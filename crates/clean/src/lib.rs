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
