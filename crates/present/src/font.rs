//! The one font of every plot and figure: the bundled DejaVu Sans (assets/fonts, Bitstream Vera
//! licence), registered as `sans-serif`, so nothing is needed from the system at run time; the
//! text sizes it is drawn at, a title's size for its width, and numbers as tick labels.

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

/// `x` to `digits` significant digits, as a tick label: plain decimals from 10⁻² to below 10⁴
/// (`0.0123`, `251`, `6310`), else `6.31e4`; no trailing zeros. Domain: any finite `x` (`0` is
/// "0"); a non-finite one is printed as Rust prints it.
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = digits.max(1);
    let e = x.abs().log10().floor() as i32;
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (-2..4).contains(&e) {
        let decimals = (digits as i32 - 1 - e).max(0) as usize;
        trim(format!("{x:.decimals$}"))
    } else {
        let s = format!("{:.*e}", digits - 1, x);
        let (m, exp) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{exp}", trim(m.to_string()))
    }
}

/// The caption size of a figure `width` pixels wide: 22, or smaller (to 14) where the title
/// would not fit (DejaVu Sans averages about 0.55 em a character); always even (see
/// [`TEXT_SIZES`]).
pub(crate) fn caption_size(title: &str, width: u32) -> u32 {
    let chars = title.chars().count().max(1) as f64;
    let fits = (f64::from(width.saturating_sub(24)) / (0.55 * chars)).floor() as u32;
    (fits.min(22) & !1).max(14)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_title_too_long_for_its_figure_is_drawn_smaller_at_an_even_size() {
        // 0.55 em a character: a short title keeps 22 px; the probe front's 95-character title
        // on 900 px fits at 16; nothing goes below 14, and every size is even.
        assert_eq!(super::caption_size("error against rays", 900), 22);
        let long = "speed against accuracy per run, with the Pareto front (bars: spread of the timed repeats)";
        let s = super::caption_size(long, 900);
        assert!(s < 22 && s.is_multiple_of(2), "{s}");
        assert!(
            long.chars().count() as f64 * 0.55 * f64::from(s) <= 876.0,
            "{s}"
        );
        assert_eq!(super::caption_size(&"x".repeat(1000), 900), 14);
        for w in [300, 620, 900, 1860] {
            for n in [1, 40, 80, 160] {
                let s = super::caption_size(&"y".repeat(n), w);
                assert!(s.is_multiple_of(2) && (14..=22).contains(&s), "{w} {n} {s}");
            }
        }
    }

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
