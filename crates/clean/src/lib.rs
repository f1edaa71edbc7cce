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
