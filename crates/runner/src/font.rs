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

/// Text sizes (plotters' font size, pixels) the plots and figures use. plotters 0.3.7 places each
/// glyph at `(size / 2 + top) as i32` (truncated toward zero), so at an odd size a glyph whose top
/// is near the baseline — the decimal point — is drawn a pixel above the others' baseline, and
/// small labels read "1·1". Even sizes are placed exactly; every text is drawn at one of these.
pub const TEXT_SIZES: [u32; 6] = [12, 14, 16, 18, 20, 22];

#[cfg(test)]
mod tests {
    use plotters::prelude::*;

    /// The lowest dark row of each run of dark columns of "1.1" drawn at `size`.
    fn glyph_bottoms(size: u32) -> Vec<usize> {
        super::ensure_font();
        let (w, h) = (120usize, 60usize);
        let mut buf = vec![255u8; w * h * 3];
        {
            let root =
                BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
            let font = ("sans-serif", size).into_font();
            root.draw(&Text::new("1.1", (4, 8), font)).unwrap();
            root.present().unwrap();
        }
        let dark = |x: usize, y: usize| buf[(y * w + x) * 3] < 128;
        let mut bottoms = Vec::new();
        let mut x = 0;
        while x < w {
            if (0..h).any(|y| dark(x, y)) {
                let mut bottom = 0;
                while x < w && (0..h).any(|y| dark(x, y)) {
                    bottom = bottom.max((0..h).filter(|&y| dark(x, y)).max().unwrap());
                    x += 1;
                }
                bottoms.push(bottom);
            }
            x += 1;
        }
        bottoms
    }

    #[test]
    fn the_decimal_point_sits_on_the_baseline_at_every_size_used() {
        for size in super::TEXT_SIZES {
            let b = glyph_bottoms(size);
            assert_eq!(b.len(), 3, "size {size}: glyph runs {b:?}");
            println!("size {size}: bottom rows of 1 . 1: {b:?}");
            assert!(
                b[1].abs_diff(b[0]) == 0 && b[2] == b[0],
                "size {size}: {b:?}"
            );
        }
        // The check can fail: at an odd size plotters lifts the point.
        let odd = glyph_bottoms(13);
        println!("size 13: bottom rows of 1 . 1: {odd:?}");
        assert_ne!(odd[1], odd[0], "size 13 no longer lifts the point: {odd:?}");
    }
}
