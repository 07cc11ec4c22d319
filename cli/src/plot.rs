//! PNG charts drawn with plotters' bitmap backend: the per-frame budget bars of `run --overlays`
//! and the error-versus-cost curves of `bench`.
//!
//! Text needs a TrueType font: the first of `$VRRT_PLOT_FONT` and a few usual system paths that
//! exists is registered once; without one the charts are drawn without any text.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// True once a font is registered for chart text.
pub fn has_font() -> bool {
    static FONT: OnceLock<bool> = OnceLock::new();
    *FONT.get_or_init(|| {
        let candidates = std::env::var("VRRT_PLOT_FONT")
            .ok()
            .into_iter()
            .chain(FONT_PATHS.iter().map(|s| s.to_string()));
        for path in candidates {
            if let Ok(bytes) = std::fs::read(&path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

/// Encodes tightly packed RGB8 as a PNG file, written through a temporary file renamed over
/// `path` (a link there is replaced, not followed).
fn write_rgb_png(path: &Path, rgb: &[u8], (w, h): (u32, u32)) -> Result<()> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc
        .write_header()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    writer
        .finish()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    vrrt_scene::safe_fs::write_atomic(path, &bytes)
        .map_err(|e| anyhow!("cannot write {}: {e}", path.display()))
}

fn draw_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing a chart: {e}")
}

/// A bar chart of a frame's ray accounting (requested, granted, budget, traced).
pub fn budget_bars(path: &Path, frame: u32, bars: &[(&str, f64)]) -> Result<()> {
    let size = (360u32, 240u32);
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    let text = has_font();
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let max = bars.iter().map(|b| b.1).fold(1.0f64, f64::max) * 1.1;
        let n = bars.len() as f64;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(8);
        if text {
            builder
                .caption(format!("frame {frame}: rays"), ("sans-serif", 16))
                .x_label_area_size(24)
                .y_label_area_size(56);
        }
        let mut chart = builder
            .build_cartesian_2d(0.0..n, 0.0..max)
            .map_err(draw_err)?;
        let names: Vec<String> = bars.iter().map(|b| b.0.to_string()).collect();
        let x_fmt = |x: &f64| {
            let i = x.floor() as usize;
            if (x - x.floor() - 0.5).abs() < 0.01 && i < names.len() {
                names[i].clone()
            } else {
                String::new()
            }
        };
        let y_fmt = |y: &f64| format!("{y:.0}");
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh();
        if text {
            mesh.x_labels(bars.len() * 2 + 1)
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt);
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw().map_err(draw_err)?;
        let colors = [BLUE, GREEN, BLACK, RED];
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                let x = i as f64;
                Rectangle::new(
                    [(x + 0.15, 0.0), (x + 0.85, b.1)],
                    colors[i % colors.len()].filled(),
                )
            }))
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    write_rgb_png(path, &rgb, size)
}

/// One curve of [`curves`]: a name and its points.
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// `(x, y)` points, drawn in x order.
    pub points: Vec<(f64, f64)>,
}

/// A line chart of several curves with a logarithmic y axis (errors span decades).
pub fn curves(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    curves: &[Curve],
) -> Result<()> {
    let size = (800u32, 560u32);
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    let text = has_font();
    let finite = |v: &f64| v.is_finite();
    let xs: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.0))
        .filter(finite)
        .collect();
    let ys: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite() && *y > 0.0)
        .collect();
    if xs.is_empty() || ys.is_empty() {
        return Ok(());
    }
    let (x0, x1) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    let (y0, y1) = ys
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &y| (a.min(y), b.max(y)));
    let pad = ((x1 - x0) * 0.05).max(1e-3);
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(12);
        if text {
            builder
                .caption(title, ("sans-serif", 20))
                .x_label_area_size(40)
                .y_label_area_size(70);
        }
        let mut chart = builder
            .build_cartesian_2d(
                (x0 - pad).max(0.0)..x1 + pad,
                (y0 / 1.3..y1 * 1.3).log_scale(),
            )
            .map_err(draw_err)?;
        let y_fmt = |y: &f64| format!("{y:.1e}");
        let mut mesh = chart.configure_mesh();
        if text {
            mesh.x_desc(x_desc).y_desc(y_desc).y_label_formatter(&y_fmt);
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw().map_err(draw_err)?;
        for (i, c) in curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let mut pts: Vec<(f64, f64)> = c
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite() && p.1 > 0.0)
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let series = chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(draw_err)?;
            if text {
                series.label(c.name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            }
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(draw_err)?;
        }
        if text {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    write_rgb_png(path, &rgb, size)
}
