//! Renders the generator's contact sheet shown in the README: one frame of a city and of a
//! highway sudden-braking scenario in each weather, and for one frame its ground truth
//! (boxes, AnoVox semantic ids, exact optical flow, depth).
//!
//! Run: `cargo run --release --example contact_sheet -- docs/synth_contact_sheet.png`

use std::path::PathBuf;

use image::{Rgb, RgbImage, imageops};
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use vadscope::flow::{FlowColorRange, colorize_flow};
use vadscope::sequence::{Domain, FrameRecord, Weather, palette};
use vadscope::synth::{Scenario, ScenarioKind, ScenarioSpec};

const TILE_W: u32 = 384;
const TILE_H: u32 = 256;
const CAPTION_H: u32 = 26;
const SEED: u64 = 11;

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or("docs/synth_contact_sheet.png".into()),
    );
    register_font(
        "sans-serif",
        FontStyle::Normal,
        include_bytes!("../assets/fonts/DejaVuSans.ttf"),
    )
    .map_err(|_| anyhow::anyhow!("bundled font is not a valid TrueType file"))?;

    let weathers = [Weather::Sun, Weather::Rain, Weather::Fog, Weather::Night];
    let mut tiles: Vec<(RgbImage, String)> = Vec::new();
    let mut ground_truth_frame = None;
    for domain in [Domain::City, Domain::Highway] {
        for weather in weathers {
            let mut spec = ScenarioSpec::new(ScenarioKind::Braking, domain, weather, SEED);
            spec.width = TILE_W;
            spec.height = TILE_H;
            spec.frames = 120;
            let scenario = Scenario::build(&spec)?;
            let window = scenario.anomaly_window();
            let frame = window.map_or(60, |w| w.start as usize + 4);
            let record = scenario.render_frame(frame)?;
            let caption = format!("{domain:?} · {weather:?} · frame {frame} (lead braking)");
            if domain == Domain::City && weather == Weather::Sun {
                ground_truth_frame = Some(record.clone());
            }
            tiles.push((record.rgb, caption));
        }
    }
    let gt = ground_truth_frame.expect("the city/sun tile is rendered above");
    tiles.extend(ground_truth_tiles(&gt));

    let columns = 4;
    let rows = tiles.len().div_ceil(columns) as u32;
    let cell_h = TILE_H + CAPTION_H;
    let mut sheet = RgbImage::from_pixel(columns as u32 * TILE_W, rows * cell_h, Rgb([24, 24, 28]));
    for (i, (tile, _)) in tiles.iter().enumerate() {
        let (x, y) = (
            (i % columns) as u32 * TILE_W,
            (i / columns) as u32 * cell_h + CAPTION_H,
        );
        imageops::replace(&mut sheet, tile, x as i64, y as i64);
    }
    let (w, h) = sheet.dimensions();
    {
        let root = BitMapBackend::with_buffer(sheet.as_mut(), (w, h)).into_drawing_area();
        let style = ("sans-serif", 15).into_font().color(&WHITE);
        for (i, (_, caption)) in tiles.iter().enumerate() {
            let (x, y) = (
                (i % columns) as u32 * TILE_W + 6,
                (i / columns) as u32 * cell_h + 7,
            );
            root.draw_text(caption, &style, (x as i32, y as i32))?;
        }
        root.present()?;
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    sheet.save(&out)?;
    println!("wrote {}", out.display());
    Ok(())
}

/// The ground truth of one frame: RGB with its boxes, semantic ids, flow, depth.
fn ground_truth_tiles(record: &FrameRecord) -> Vec<(RgbImage, String)> {
    let mut boxed = record.rgb.clone();
    for b in &record.boxes {
        let colour = if b.anomalous {
            Rgb([255, 40, 40])
        } else {
            Rgb([60, 255, 120])
        };
        draw_rect(
            &mut boxed,
            b.x1 as i64,
            b.y1 as i64,
            b.x2 as i64 - 1,
            b.y2 as i64 - 1,
            colour,
        );
    }
    let mut tiles = vec![(
        boxed,
        "ground-truth boxes (red: anomalous lead)".to_string(),
    )];
    if let Some(semantic) = &record.semantic {
        tiles.push((
            palette::colourise(semantic),
            "SEMANTIC_IMG (AnoVox ids; 100 = anomaly)".into(),
        ));
    }
    if let Some(flow) = &record.flow {
        tiles.push((
            colorize_flow(flow, FlowColorRange::Fixed(8.0)),
            "OPTICAL_FLOW (exact; colour wheel, 8 px = full)".into(),
        ));
    }
    if let Some(depth) = &record.depth_m {
        let depth_tile = RgbImage::from_fn(record.rgb.width(), record.rgb.height(), |x, y| {
            let d = depth[(y * record.rgb.width() + x) as usize];
            let g = (255.0 * (1.0 - (d.max(1.0).ln() / 100f32.ln()).min(1.0))) as u8;
            Rgb([g, g, g])
        });
        tiles.push((depth_tile, "DEPTH_IMG (near = bright, log scale)".into()));
    }
    tiles
}

fn draw_rect(img: &mut RgbImage, x1: i64, y1: i64, x2: i64, y2: i64, colour: Rgb<u8>) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let mut put = |x: i64, y: i64| {
        if (0..w).contains(&x) && (0..h).contains(&y) {
            img.put_pixel(x as u32, y as u32, colour);
        }
    };
    for x in x1..=x2 {
        put(x, y1);
        put(x, y2);
    }
    for y in y1..=y2 {
        put(x1, y);
        put(x2, y);
    }
}
