//! Line charts drawn with plotters into images, for `profile --plot` and `bench --plot`.

use std::sync::Once;

use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::output::{PendingFile, is_stdout};

/// Bundled so plot text renders the same everywhere (Bitstream Vera licence,
/// see assets/fonts/DejaVuSans-LICENSE.txt).
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// What drawing returns: plotters' errors are of many types.
pub type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// The whole canvas.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// A chart with a linear x axis and a y axis `Y` (linear or logarithmic), both in `f64`.
pub type Chart<'a, 'b, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, Y>>;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Only fails for a malformed font, which the bundled file is not.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// An image of `size` pixels: white, then what `draw` puts on it.
pub fn draw_image(
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> DrawResult,
) -> Result<image::RgbImage> {
    register_font();
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let drawn: DrawResult = (|| {
            root.fill(&WHITE)?;
            draw(&root)?;
            root.present()?;
            Ok(())
        })();
        drawn.map_err(|e| anyhow!("drawing failed: {e}"))?;
    }
    Ok(image::RgbImage::from_raw(size.0, size.1, buf).expect("w * h RGB pixels"))
}

/// A chart builder on `area`: `caption` above, and room for the axes' labels (`y_labels`
/// pixels wide at the left).
pub fn chart_builder<'a, 'b>(
    area: &'a Area<'b>,
    caption: impl AsRef<str>,
    y_labels: u32,
) -> ChartBuilder<'a, 'a, BitMapBackend<'b>> {
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(y_labels);
    builder
}

/// Draws `chart`'s grid and axes, described by `x_desc` and `y_desc`; a logarithmic y axis
/// (`log_y`) labels its decades as powers of ten.
pub fn axes<Y>(chart: &mut Chart<'_, '_, Y>, x_desc: &str, y_desc: &str, log_y: bool) -> DrawResult
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let powers = |v: &f64| format!("{v:.0e}");
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", 14));
    if log_y {
        mesh.y_label_formatter(&powers);
    }
    mesh.draw()?;
    Ok(())
}

/// A solid line 2 pixels wide, with an entry in the legend.
pub fn line<Y, C>(
    chart: &mut Chart<'_, '_, Y>,
    points: impl IntoIterator<Item = (f64, f64)>,
    color: C,
    label: impl Into<String>,
) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
    C: Color + Copy + 'static,
{
    chart
        .draw_series(LineSeries::new(points, color.stroke_width(2)))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    Ok(())
}

/// A dashed line 2 pixels wide (dashes `dash` pixels long, `gap` apart), not in the legend.
pub fn dashed<Y, C, I>(
    chart: &mut Chart<'_, '_, Y>,
    points: I,
    color: C,
    (dash, gap): (u32, u32),
) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
    C: Color,
    I: IntoIterator<Item = (f64, f64)>,
    I::IntoIter: Clone,
{
    chart.draw_series(DashedLineSeries::new(
        points,
        dash,
        gap,
        color.stroke_width(2),
    ))?;
    Ok(())
}

/// The legend of the labelled lines, in a box over the chart, its text `font_size` high.
pub fn legend<'a, 'b: 'a, Y>(chart: &mut Chart<'a, 'b, Y>, font_size: u32) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
{
    chart
        .configure_series_labels()
        .label_font(("sans-serif", font_size))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// The line colours of the red, green and blue channels.
pub const CHANNEL_COLORS: [RGBColor; 3] = [
    RGBColor(220, 40, 30),
    RGBColor(30, 160, 50),
    RGBColor(40, 70, 220),
];
pub const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];

/// The output of `--plot`: a PNG file (created now, so that a bad path fails before any work)
/// or `-` for standard output.
pub fn create_plot(path: &Path) -> Result<PendingFile> {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !png && !is_stdout(path) {
        bail!(
            "--plot: file name must end in .png (got {})",
            path.display()
        );
    }
    PendingFile::create(path).context("--plot")
}
