//! Readers and writers of the formats the UG tools bridge to:
//!
//! | module | reads | writes | tools |
//! |---|---|---|---|
//! | [`obj`] | Wavefront OBJ with MTL libraries | [`obj::write`]: OBJ + MTL (radiosity as vertex colours) | obj2ug, ug2obj |
//! | [`ply`] | PLY (ASCII and binary) | [`ply::write`]: PLY (lit models with radiosity per vertex) | ply2ug, ug2ply |
//! | [`mgf`] | MGF 2.0 (Greg Ward's Materials and Geometry Format) | – | mgf2ug |
//!
//! Every reader returns a [`ug::Model`] and its warnings; every error names
//! the file, line and column. The text helpers the readers share (tokenizer,
//! name sanitising, warnings) live in [`obj`] and [`obj::names`].

pub mod mgf;
pub mod obj;
pub mod ply;
