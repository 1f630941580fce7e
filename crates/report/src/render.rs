//! What every figure shares: the bundled font, and rendering to PNG or SVG by the file's extension
//! (for the figures that are data first, only when a file is asked for).

use std::error::Error;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use crate::ReportError;

/// DejaVu Sans 2.37 (Bitstream Vera license, see `assets/fonts/DejaVuSans-LICENSE.txt`),
/// compiled in so that no system font or fontconfig is ever needed.
static DEJAVU_SANS: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
pub(crate) const FONT: &str = "sans-serif";

pub(crate) type DrawResult = Result<(), Box<dyn Error>>;

/// A figure that knows its size and draws itself on any plotters backend.
pub(crate) trait Drawing {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;
}

/// Draws `figure` into `path`: a PNG or an SVG by its extension.
pub(crate) fn render(figure: &impl Drawing, path: &Path) -> Result<(), ReportError> {
    register_bundled_font()?;
    let size = figure.size();
    let drawn = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            figure.draw(&root).and_then(|()| Ok(root.present()?))
        }
        Some("svg") => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            figure.draw(&root).and_then(|()| Ok(root.present()?))
        }
        _ => {
            return Err(ReportError::Extension {
                path: path.display().to_string(),
                expected: ".png or .svg",
            });
        }
    };
    drawn.map_err(|e| ReportError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// `figure`, drawn into `path` when one is given.
pub(crate) fn drawn<F>(
    figure: F,
    path: Option<&Path>,
    draw: fn(&F, &Path) -> Result<(), ReportError>,
) -> Result<F, ReportError> {
    if let Some(path) = path {
        draw(&figure, path)?;
    }
    Ok(figure)
}

/// Draws `figure` as an SVG document in memory (the status page serves it as is).
pub(crate) fn render_svg(figure: &impl Drawing) -> Result<String, ReportError> {
    register_bundled_font()?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, figure.size()).into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| Ok(root.present()?))
            .map_err(|e| ReportError::Draw {
                path: "(svg in memory)".into(),
                message: e.to_string(),
            })?;
    }
    Ok(svg)
}

/// Registers the bundled font under plotters' `sans-serif` family, once per process.
fn register_bundled_font() -> Result<(), ReportError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok =
        *REGISTERED.get_or_init(|| register_font(FONT, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok { Ok(()) } else { Err(ReportError::Font) }
}
