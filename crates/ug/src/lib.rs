//! The UniGrafix (UG) language: lexer, parser with source positions, [`Model`],
//! canonical writer and instance flattening. No geometry algorithms live here.
//!
//! ```
//! let src = b"c_rgb red 0.9 0.2 0.2; v a 0 0 0; v b 1 0 0; v c 0 1 0; f t (a b c) red;";
//! let parsed = ug::parse(src, "<doc>").unwrap();
//! assert_eq!(parsed.model.faces.len(), 1);
//! let text = ug::write_string(&parsed.model);
//! assert_eq!(ug::parse(text.as_bytes(), "<doc>").unwrap().model, parsed.model);
//! ```

pub mod error;
pub mod flatten;
pub mod lexer;
pub mod model;
pub mod parser;
pub mod writer;

pub use error::{Diagnostic, Level, Pos};
pub use flatten::{FlattenLimits, transform_matrix};
pub use model::*;
pub use parser::{
    IncludeMode, MAX_COORDINATE, MIN_EXTENT, ParseOptions, Parsed, parse, parse_file, parse_with,
};
pub use writer::{fmt_f64, push_f64, write, write_string};
