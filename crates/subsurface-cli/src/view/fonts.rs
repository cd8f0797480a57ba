//! Fonts for the panel. The workspace builds egui without its `default_fonts` feature (it
//! would download egui's font package), so the panel uses the DejaVu Sans that the project
//! already vendors for plots (assets/fonts, Bitstream Vera licence); `SUBSURFACE_VIEW_FONT`
//! may name another TTF.

use std::sync::Arc;

use egui::{FontData, FontDefinitions, FontFamily};

static DEJAVU_SANS: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");

/// The font definitions to install. Fails only when `SUBSURFACE_VIEW_FONT` names a file that
/// cannot be read.
pub fn definitions() -> Result<FontDefinitions, String> {
    let (name, data) = match std::env::var_os("SUBSURFACE_VIEW_FONT") {
        Some(p) => {
            let bytes = std::fs::read(&p)
                .map_err(|e| format!("SUBSURFACE_VIEW_FONT={}: {e}", p.to_string_lossy()))?;
            (
                p.to_string_lossy().into_owned(),
                FontData::from_owned(bytes),
            )
        }
        None => ("DejaVuSans".to_string(), FontData::from_static(DEJAVU_SANS)),
    };
    let mut defs = FontDefinitions::empty();
    defs.font_data.insert(name.clone(), Arc::new(data));
    defs.families
        .insert(FontFamily::Proportional, vec![name.clone()]);
    defs.families.insert(FontFamily::Monospace, vec![name]);
    Ok(defs)
}
