//! The one font of every plot and figure: the bundled DejaVu Sans (assets/fonts, Bitstream Vera
//! licence), registered as `sans-serif`, so nothing is needed from the system at run time.

use plotters::prelude::FontStyle;

static FONT: std::sync::Once = std::sync::Once::new();

/// Register the bundled DejaVu Sans as `sans-serif` (once); every plot and figure calls it.
pub fn ensure_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
        // Registration fails only for a malformed font, which the tests would catch.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}
