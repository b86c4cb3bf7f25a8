//! Presentation — what the project shows people, on the ground floor beside the files it is
//! written through (docs/ARCHITECTURE.md). It imports nothing numerical: only the durable files
//! and the results table of `shscale_files`, plotters and the image codecs.
//!
//! | module | what |
//! |---|---|
//! | [`plots`] | line plots of a results table, speed/accuracy scatters with their fronts, multi-panel figures |
//! | [`column_plot`] | `shscale plot`: any column of a table against another |
//! | [`heatmap`] | heatmaps of a table's cells |
//! | [`figure`] | labelled image grids with colour bars (PNG) |
//! | [`image`] | EXR and PNG files, written durably; EXR radiance maps read with their checks |
//! | [`font`] | the bundled DejaVu Sans, caption sizes, significant digits |
//! | [`markdown`] | Markdown cells and text escaped; a report's Markdown as standalone HTML |
//!
//! The report itself — which sections a kind's summary has, in which order, from its manifest —
//! is the runner's (`shscale_runner::report`), which calls these.

pub mod column_plot;
pub mod error;
pub mod figure;
pub mod font;
pub mod heatmap;
pub mod image;
pub mod markdown;
pub mod plots;

pub use error::Error;
