//! The report's plots (PNG, plotters): bake time against depth per strategy, image error
//! against time per frame per view (the hit modes' Pareto curves), and the octree against
//! the dense-grid DDA.

use crate::bake_tables::BakeTables;
use crate::image_tables::{DdaRow, ImageRow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;
use svo::Strategy;

/// Registers a TrueType font for the plots' text (plotters draws no text without one).
pub fn register_font() -> anyhow::Result<()> {
    for p in [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/usr/share/fonts/dejavu/DejaVuSans.ttf",
        "/Library/Fonts/Arial.ttf",
    ] {
        if let Ok(bytes) = std::fs::read(p) {
            plotters::style::register_font(
                "sans-serif",
                FontStyle::Normal,
                Box::leak(bytes.into_boxed_slice()),
            )
            .map_err(|_| anyhow::anyhow!("cannot use the font {p}"))?;
            return Ok(());
        }
    }
    anyhow::bail!("no TrueType font found for the plots (install fonts-dejavu-core)")
}

/// Draws a plot of `size` pixels with `draw` into an RGB buffer and writes it to `path` as
/// PNG.
fn png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        draw(&root)?;
        root.present()?;
    }
    image::save_buffer_with_format(
        path,
        &buf,
        size.0,
        size.1,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )?;
    Ok(())
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(0, 0, 0),
];

/// Bake time (ms, log scale) against depth, one line per strategy.
pub fn bake_time(t: &BakeTables, path: &Path, caption: &str) -> anyhow::Result<()> {
    png(path, (900, 520), |root| {
        root.fill(&WHITE)?;
        let all: Vec<f64> = t.cells.iter().flatten().map(|c| c.seconds * 1e3).collect();
        let lo = all.iter().copied().fold(f64::INFINITY, f64::min).max(1e-3) * 0.7;
        let hi = all.iter().copied().fold(0.0, f64::max) * 1.4;
        let (d0, d1) = (
            f64::from(*t.depths.first().unwrap_or(&1)),
            f64::from(*t.depths.last().unwrap_or(&1)),
        );
        let mut c = ChartBuilder::on(root)
            .caption(caption, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(d0 - 0.2..d1 + 0.2, (lo..hi).log_scale())?;
        c.configure_mesh()
            .x_desc("depth")
            .y_desc("ms, median (log)")
            .draw()?;
        for (si, s) in Strategy::ALL.iter().enumerate() {
            let colour = COLOURS[si % COLOURS.len()];
            let pts: Vec<(f64, f64)> = t
                .depths
                .iter()
                .zip(&t.cells[si])
                .map(|(&d, cell)| (f64::from(d), cell.seconds * 1e3))
                .collect();
            c.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?
                .label(s.name())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            c.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        c.configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        Ok(())
    })
}

/// The capped PSNR of the plots (dB): identical images are drawn at 70.
fn capped(psnr: f64) -> f64 {
    psnr.min(70.0)
}

type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart of PSNR against ms per frame on `root`, from 0 to `max_ms`, its PSNR axis the span
/// of the (capped) values `psnr` with `below` dB under it and 2 above (0 to 70 dB without
/// values), with its mesh drawn; and the span's low end.
fn psnr_chart<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    caption: &str,
    max_ms: f64,
    psnr: impl Iterator<Item = f64>,
    below: f64,
) -> anyhow::Result<(Chart<'a, 'b>, f64)> {
    let (lo, hi) = psnr.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lo, hi) = if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 70.0)
    };
    let mut c = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..max_ms, (lo - below).floor()..(hi + 2.0).ceil())?;
    c.configure_mesh()
        .x_desc("ms per frame (median)")
        .y_desc("PSNR vs triangles, dB (capped at 70)")
        .draw()?;
    Ok((c, lo))
}

/// A curve through `pts` (ms, PSNR, the point's label) in `colour`, named `name` in the
/// legend, each point marked and labelled.
fn labelled_curve(
    c: &mut Chart<'_, '_>,
    name: &str,
    colour: RGBColor,
    pts: &[(f64, f64, String)],
) -> anyhow::Result<()> {
    c.draw_series(LineSeries::new(
        pts.iter().map(|p| (p.0, p.1)),
        colour.stroke_width(2),
    ))?
    .label(name)
    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    c.draw_series(pts.iter().map(|(x, y, label)| {
        EmptyElement::at((*x, *y))
            + Circle::new((0, 0), 3, colour.filled())
            + Text::new(label.clone(), (5, -12), ("sans-serif", 12))
    }))?;
    Ok(())
}

/// PSNR against ms per frame for one view: one curve per hit mode through the depths, and
/// the triangle reference's median as a marker.
pub fn error_vs_time(rows: &[ImageRow], path: &Path, caption: &str) -> anyhow::Result<()> {
    png(path, (900, 560), |root| {
        root.fill(&WHITE)?;
        let shown: Vec<&ImageRow> = rows.iter().filter(|r| r.mode != "triangles").collect();
        let max_ms = rows.iter().map(|r| r.seconds * 1e3).fold(1.0, f64::max) * 1.1;
        let psnr = shown.iter().map(|r| capped(r.psnr));
        let (mut c, lo) = psnr_chart(root, caption, max_ms, psnr, 3.0)?;
        for (mode, colour) in [
            ("cube", COLOURS[0]),
            ("contour", COLOURS[1]),
            ("exact", COLOURS[2]),
        ] {
            let pts: Vec<(f64, f64, String)> = shown
                .iter()
                .filter(|r| r.mode == mode)
                .map(|r| (r.seconds * 1e3, capped(r.psnr), format!("d{}", r.depth)))
                .collect();
            labelled_curve(&mut c, mode, colour, &pts)?;
        }
        let ref_ms: Vec<f64> = rows
            .iter()
            .filter(|r| r.mode == "triangles")
            .map(|r| r.seconds * 1e3)
            .collect();
        if !ref_ms.is_empty() {
            let ms = crate::report::median(&ref_ms);
            let y = (lo - 2.0).floor();
            c.draw_series(std::iter::once(
                EmptyElement::at((ms, y))
                    + TriangleMarker::new((0, 0), 6, BLACK.filled())
                    + Text::new("triangles (BVH), median", (8, -6), ("sans-serif", 13)),
            ))?;
        }
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        Ok(())
    })
}

/// PSNR against ms per frame at each level of detail for one view: against the one-sample
/// and the 16-sample triangle references, each point labelled with its `--lod`.
pub fn lod_error_vs_time(
    rows: &[crate::lod_tables::LodRow],
    path: &Path,
    caption: &str,
) -> anyhow::Result<()> {
    png(path, (900, 560), |root| {
        root.fill(&WHITE)?;
        let max_ms = rows.iter().map(|r| r.seconds * 1e3).fold(1.0, f64::max) * 1.1;
        let psnr = rows
            .iter()
            .flat_map(|r| std::iter::once(r.psnr).chain(r.psnr16).map(capped));
        let (mut c, _) = psnr_chart(root, caption, max_ms, psnr, 2.0)?;
        for (name, colour, sixteen) in [
            ("against 1 sample a pixel", COLOURS[0], false),
            ("against 16 samples a pixel", COLOURS[1], true),
        ] {
            let pts: Vec<(f64, f64, String)> = rows
                .iter()
                .filter_map(|r| {
                    let y = if sixteen { r.psnr16? } else { r.psnr };
                    Some((r.seconds * 1e3, capped(y), format!("lod {}", r.lod)))
                })
                .collect();
            if !pts.is_empty() {
                labelled_curve(&mut c, name, colour, &pts)?;
            }
        }
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        Ok(())
    })
}

/// Octree and DDA ms per frame against depth.
pub fn octree_vs_dda(rows: &[DdaRow], path: &Path) -> anyhow::Result<()> {
    png(path, (900, 480), |root| {
        root.fill(&WHITE)?;
        let max_ms = rows
            .iter()
            .map(|r| r.octree.max(r.dda) * 1e3)
            .fold(1.0, f64::max)
            * 1.15;
        let (d0, d1) = (
            rows.first().map_or(4, |r| r.depth),
            rows.last().map_or(10, |r| r.depth),
        );
        let mut c = ChartBuilder::on(root)
            .caption(
                "Primary rays, cube hits: octree against dense-grid DDA",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(f64::from(d0) - 0.3..f64::from(d1) + 0.3, 0.0..max_ms)?;
        c.configure_mesh()
            .x_desc("depth")
            .y_desc("ms per frame (median)")
            .draw()?;
        for (i, (name, colour)) in [("octree", COLOURS[1]), ("DDA", COLOURS[0])]
            .into_iter()
            .enumerate()
        {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| {
                    (
                        f64::from(r.depth),
                        if i == 0 { r.octree } else { r.dda } * 1e3,
                    )
                })
                .collect();
            c.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            c.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        Ok(())
    })
}
