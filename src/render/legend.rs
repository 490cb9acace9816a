//! Legends drawn beside images: the vertical colour bar of a colormap with its range and
//! title, and compact number formatting for axis and legend labels.

use super::canvas::{Anchor, Canvas};
use super::colormap::Colormap;

/// Text colour of legends on the dark view background.
pub(crate) const LEGEND_TEXT: [u8; 3] = [230, 230, 230];

/// Draws a vertical colour bar in columns `x..x+w`, rows `y..y+h`: `title` above the bar
/// (wrapped on spaces into two lines when it is wider than the bar), `high` at its top (as
/// "≥ high": larger values take the top colour) and `low` at its bottom, labels to the right
/// of a bar a third of `w` wide.
#[allow(clippy::too_many_arguments)]
pub(crate) fn colour_bar(
    canvas: &mut Canvas,
    x: i32,
    y: i32,
    w: u32,
    h: u32,
    colormap: Colormap,
    (low, high): (f64, f64),
    title: &str,
) {
    let size = (f64::from(w) / 5.0).clamp(8.0, 13.0);
    let line = Canvas::text_size("Ag", size).1 as i32 + 2;
    let mut lines: Vec<String> = Vec::new();
    for word in title.split(' ') {
        match lines.last_mut() {
            Some(last)
                if (Canvas::text_size(&format!("{last} {word}"), size).0 as i32) < w as i32 =>
            {
                last.push(' ');
                last.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    for (k, text) in lines.iter().enumerate() {
        canvas.text(
            x,
            y + k as i32 * line,
            text,
            size,
            LEGEND_TEXT,
            Anchor::TopLeft,
        );
    }
    let top = y + lines.len() as i32 * line + line / 2;
    let bottom = y + h as i32 - line / 2;
    if bottom - top < 4 {
        return;
    }
    let bar_w = (w as i32 / 3).max(4);
    let lut = colormap.lut();
    for row in top..bottom {
        let t = (bottom - 1 - row) as f32 / (bottom - top - 1).max(1) as f32;
        let color = lut[(t * 255.0).round() as usize];
        canvas.fill_rect(x, row, x + bar_w, row + 1, color, 1.0);
    }
    canvas.outline_rect(x, top, x + bar_w, bottom, [90, 90, 90], 1);
    let lx = x + bar_w + 3;
    canvas.text(
        lx,
        top,
        &format!("≥{}", short_number(high)),
        size,
        LEGEND_TEXT,
        Anchor::TopLeft,
    );
    canvas.text(
        lx,
        (top + bottom) / 2,
        &short_number(0.5 * (low + high)),
        size,
        LEGEND_TEXT,
        Anchor::MiddleLeft,
    );
    canvas.text(
        lx,
        bottom - line + 2,
        &short_number(low),
        size,
        LEGEND_TEXT,
        Anchor::TopLeft,
    );
}

/// A number in at most about five characters: 0.123, 12.3, 1234, 1.2e5.
pub(crate) fn short_number(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.1e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}
