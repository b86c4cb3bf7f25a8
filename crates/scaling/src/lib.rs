//! SH scaling.
