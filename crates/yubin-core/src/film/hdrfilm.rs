//! `hdrfilm`: the film that records linear RGB, written to the file given
//! with `-o` (EXR with every layer, or a clamped sRGB PNG).
//!
//! | parameter                      | type    | default | meaning                      |
//! |--------------------------------|---------|---------|------------------------------|
//! | `width`, `height`              | integer | 768, 576| image size in pixels         |
//! | `crop_offset_x`, `crop_offset_y` | integer | 0     | top-left of the crop window  |
//! | `crop_width`, `crop_height`    | integer | full    | size of the crop window      |
//! | `pixel_format`, `component_format` | string | `rgb`, `float16` | accepted as Mitsuba's values; yubin writes RGB |
//! | (child) `rfilter`              | rfilter | gaussian| reconstruction filter        |
//!
//! ```xml
//! <film type="hdrfilm">
//!     <integer name="width" value="1920"/>
//!     <integer name="height" value="1080"/>
//!     <rfilter type="tent"/>
//! </film>
//! ```
//!
//! `sample_border` is not supported (a warning says so); Mitsuba 0.6's
//! `file_format`, `banner`, `high_quality_edges` and `attach_log` are
//! ignored with a warning.

use super::Film;
use crate::filter::Filter;
use crate::params::{Family, ParamError, Params};

/// The output formats Mitsuba's `hdrfilm` accepts (yubin writes RGB).
const PIXEL_FORMATS: &[&str] = &["rgb", "rgba", "luminance", "luminance_alpha", "xyz", "xyza"];
const COMPONENT_FORMATS: &[&str] = &["float16", "float32", "uint32"];

/// Builds an `hdrfilm`.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Film, ParamError> {
    let width = p.positive_integer_or("width", 768)?;
    let height = p.positive_integer_or("height", 576)?;
    let ox = p.integer_or("crop_offset_x", 0)?.max(0) as u32;
    let oy = p.integer_or("crop_offset_y", 0)?.max(0) as u32;
    let cw = p.positive_integer_or("crop_width", (width.saturating_sub(ox)).max(1) as i64)?;
    let ch = p.positive_integer_or("crop_height", (height.saturating_sub(oy)).max(1) as i64)?;
    if ox + cw > width || oy + ch > height {
        return Err(p.error(&format!(
            "the crop window {cw}x{ch}+{ox}+{oy} does not fit in the {width}x{height} film"
        )));
    }
    for (name, allowed) in [
        ("pixel_format", PIXEL_FORMATS),
        ("component_format", COMPONENT_FORMATS),
    ] {
        if let Some(v) = p.string(name)? {
            if !allowed.contains(&v.as_str()) {
                return Err(p.param_error(
                    name,
                    &format!("must be one of {}, not \"{v}\"", allowed.join(", ")),
                ));
            }
        }
    }
    if p.boolean("sample_border")? == Some(true) {
        p.warn(
            Some("sample_border"),
            "sample_border is not supported; edge pixels see only samples from inside the film",
        );
    }
    p.warn_ignored(
        &["file_format", "banner", "high_quality_edges", "attach_log"],
        "a parameter of older Mitsuba versions; the output file is chosen with -o",
    );
    let filter = match p.child(Family::Rfilter)? {
        Some(mut f) => Filter::from_params(f.as_mut())?,
        None => Filter::default(),
    };
    Ok(Film {
        width,
        height,
        crop_offset: [ox, oy],
        crop_size: [cw, ch],
        filter,
    })
}
