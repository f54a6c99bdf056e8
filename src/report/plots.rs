//! SVG charts (plotters) for the report.

use super::data::MethodData;
use plotters::prelude::*;

const W: u32 = 720;
const H: u32 = 320;

fn palette(i: usize) -> RGBColor {
    const C: [RGBColor; 12] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
        RGBColor(57, 59, 121),
        RGBColor(173, 73, 74),
    ];
    // Past 12, vary the lightness so neighbours in a stack stay apart.
    let c = C[i % C.len()];
    if i < C.len() {
        c
    } else {
        RGBColor(c.0 / 2 + 100, c.1 / 2 + 100, c.2 / 2 + 100)
    }
}

fn finite_max(v: impl Iterator<Item = f64>) -> f64 {
    v.filter(|x| x.is_finite()).fold(0.0f64, f64::max)
}

/// One line per method: `value(frame)` against the frame index, for the
/// frames from index `first` on.
pub fn per_frame(
    methods: &[MethodData],
    title: &str,
    y_label: &str,
    first: usize,
    value: impl Fn(&super::data::FramePoint) -> Option<f64>,
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let n = methods
            .iter()
            .map(|m| m.frames.len())
            .max()
            .unwrap_or(1)
            .max(2);
        let ymax = finite_max(
            methods
                .iter()
                .flat_map(|m| m.frames.iter().filter(|f| f.index >= first))
                .filter_map(&value),
        )
        .max(1e-9)
            * 1.1;
        let mut chart = match ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(first.min(n - 2) as f64..(n - 1) as f64, 0f64..ymax)
        {
            Ok(c) => c,
            Err(_) => return svg_error(title),
        };
        let _ = chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc(y_label)
            .draw();
        for (i, m) in methods.iter().enumerate() {
            let pts: Vec<(f64, f64)> = m
                .frames
                .iter()
                .filter(|f| f.index >= first)
                .filter_map(|f| {
                    value(f)
                        .filter(|v| v.is_finite())
                        .map(|v| (f.index as f64, v))
                })
                .collect();
            let color = palette(i);
            if let Ok(s) = chart.draw_series(LineSeries::new(pts, color.stroke_width(2))) {
                s.label(m.name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                });
            }
        }
        let _ = chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw();
        let _ = root.present();
    }
    svg
}

/// Stacked bars: mean ms per pass for each method.
pub fn pass_breakdown(methods: &[MethodData]) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W + 200, H + 100)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let mut passes: Vec<String> = methods
            .iter()
            .flat_map(|m| m.pass_ms().into_keys())
            .collect();
        passes.sort();
        passes.dedup();
        let ymax =
            finite_max(methods.iter().map(|m| m.pass_ms().values().sum::<f64>())).max(1e-9) * 1.15;
        let mut chart = match ChartBuilder::on(&root)
            .caption("GPU time per pass (mean ms per frame)", ("sans-serif", 16))
            .margin(10)
            .margin_right(210)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..methods.len() as f64, 0f64..ymax)
        {
            Ok(c) => c,
            Err(_) => return svg_error("passes"),
        };
        let names: Vec<String> = methods.iter().map(|m| m.name.clone()).collect();
        let _ = chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(2 * methods.len() + 1)
            .x_label_formatter(&|x| {
                // Ticks fall on multiples of ½: name the bar centres only.
                if (x - x.floor() - 0.5).abs() < 1e-3 {
                    names.get(x.floor() as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc("ms")
            .draw();
        for (pi, p) in passes.iter().enumerate() {
            let color = palette(pi);
            let bars: Vec<Rectangle<(f64, f64)>> = methods
                .iter()
                .enumerate()
                .filter_map(|(mi, m)| {
                    let ms = m.pass_ms();
                    let v = *ms.get(p)?;
                    let below: f64 = passes[..pi].iter().filter_map(|q| ms.get(q)).sum();
                    Some(Rectangle::new(
                        [(mi as f64 + 0.2, below), (mi as f64 + 0.8, below + v)],
                        color.filled(),
                    ))
                })
                .collect();
            let _ = chart.draw_series(bars);
        }
        let entries: Vec<(String, RGBColor)> = passes
            .iter()
            .enumerate()
            .map(|(i, p)| (p.clone(), palette(i)))
            .collect();
        side_legend(&root, &entries, W as i32 + 10, 20);
        let _ = root.present();
    }
    svg
}

/// Error against frame time: one point per configuration, and per method
/// kind a line through its Pareto-optimal points (no other point of the same
/// kind is both faster and more accurate) — the figure to choose settings by.
pub fn pareto(methods: &[MethodData], metric: &str) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W + 200, H + 80)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let pts: Vec<(usize, f64, f64)> = methods
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.metric(metric).map(|e| (i, m.mean_gpu_ms(), e)))
            .filter(|p| p.1.is_finite() && p.2.is_finite())
            .collect();
        let xmax = finite_max(pts.iter().map(|p| p.1)).max(1e-9) * 1.2;
        let ymax = finite_max(pts.iter().map(|p| p.2)).max(1e-9) * 1.2;
        let mut chart = match ChartBuilder::on(&root)
            .caption(
                format!("{metric} against GPU frame time"),
                ("sans-serif", 16),
            )
            .margin(10)
            .margin_right(210)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..xmax, 0f64..ymax)
        {
            Ok(c) => c,
            Err(_) => return svg_error("pareto"),
        };
        let _ = chart
            .configure_mesh()
            .x_desc("mean GPU ms per frame (after the first)")
            .y_desc(metric)
            .draw();
        let mut kinds: Vec<String> = methods.iter().map(|m| m.kind()).collect();
        kinds.dedup();
        let mut seen: Vec<String> = Vec::new();
        for k in kinds {
            if seen.contains(&k) {
                continue;
            }
            seen.push(k.clone());
        }
        for (ki, k) in seen.iter().enumerate() {
            let color = palette(ki);
            let mut own: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| methods[p.0].kind() == *k)
                .map(|p| (p.1, p.2))
                .collect();
            own.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut front = Vec::new();
            let mut best = f64::INFINITY;
            for p in &own {
                if p.1 < best {
                    best = p.1;
                    front.push(*p);
                }
            }
            let _ = chart.draw_series(LineSeries::new(front, color.stroke_width(2)));
            let _ = chart.draw_series(own.iter().map(|p| Circle::new(*p, 4, color.filled())));
        }
        for (i, x, y) in &pts {
            let _ = chart.draw_series(std::iter::once(Text::new(
                methods[*i].name.clone(),
                (*x, *y),
                ("sans-serif", 11),
            )));
        }
        let entries: Vec<(String, RGBColor)> = seen
            .iter()
            .enumerate()
            .map(|(i, k)| (k.clone(), palette(i)))
            .collect();
        side_legend(&root, &entries, W as i32 + 10, 20);
        let _ = root.present();
    }
    svg
}

/// A legend beside the plotting area (pixel coordinates of `root`): a
/// colour swatch and the name of each series. Plotters' own series labels
/// are drawn inside the plotting area and were clipped there.
fn side_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(String, RGBColor)],
    x: i32,
    y: i32,
) {
    for (i, (name, color)) in entries.iter().enumerate() {
        let yi = y + 16 * i as i32;
        let _ = root.draw(&Rectangle::new(
            [(x, yi), (x + 12, yi + 12)],
            color.filled(),
        ));
        let _ = root.draw(&Text::new(name.clone(), (x + 18, yi), ("sans-serif", 12)));
    }
}

fn svg_error(what: &str) -> String {
    format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"40\"><text x=\"10\" y=\"25\">{what}: no data to plot</text></svg>")
}
