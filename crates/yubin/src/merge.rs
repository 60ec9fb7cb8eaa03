//! `yubin merge PART... -o IMAGE`: puts the parts of a render
//! (`yubin render --part K/N`) together into the image one `yubin render`
//! makes, bit for bit. Parts that do not belong together (another scene,
//! other settings, another yubin), the same part twice and missing parts
//! are refused, named, before anything is written.

use crate::checkpoint::differences;
use crate::denoise;
use crate::output::{write_output, DisplayArgs};
use crate::part::{self, PartHeader};
use crate::render::{check_output_format, report_nonfinite};
use anyhow::{bail, Result};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use yubin_core::film::Framebuffer;
use yubin_core::render::{
    assemble, average, tiles, NonFinite, NonFiniteSample, PassSize, RenderOutput, NONFINITE_KEPT,
    TILE_SIZE,
};

/// Arguments of `yubin merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The part files (`yubin render --part K/N`), all N of them, in any
    /// order.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The image: .exr (with the render's extra layers) or .png/.jpg.
    #[arg(short, long)]
    output: PathBuf,
    /// No summary.
    #[arg(short, long)]
    quiet: bool,
    /// How PNG/JPEG output shows the image.
    #[command(flatten)]
    display: DisplayArgs,
}

/// Checks, merges and writes.
pub fn run(args: MergeArgs) -> Result<()> {
    let t0 = Instant::now();
    check_output_format(&args.output)?;
    let display = args.display.resolve()?;
    let headers: Vec<PartHeader> = args
        .parts
        .iter()
        .map(|p| part::read_header(p))
        .collect::<Result<_>>()?;
    let first = check_belong(&args.parts, &headers)?;
    // The parts are read side by side (decoding is most of a merge).
    let read: Vec<part::PartFile> = args
        .parts
        .par_iter()
        .map(|p| part::read(p))
        .collect::<Result<_>>()?;
    let mut sums_of: Vec<&[f32]> = vec![&[]; tiles(first.crop).len()];
    for file in &read {
        for (number, data) in file.tiles() {
            sums_of[number] = data;
        }
    }
    let sums = assemble(
        first.crop,
        first.margin,
        first.channels,
        sums_of.iter().copied(),
    )
    .map_err(|e| anyhow::anyhow!("the parts do not make the image: {e}"))?;
    let mut out = output_of(first, &headers, &sums);
    report_nonfinite(&out, false);
    if first.denoise {
        denoise::denoise(&mut out)?;
    }
    write_output(&args.output, &out, &display)?;
    if !args.quiet {
        eprintln!(
            "{}: {}x{}, {} spp, merged from {} parts in {:.2} s",
            args.output.display(),
            first.crop[0],
            first.crop[1],
            first.spp,
            headers.len(),
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// Checks that the parts make one whole render: the same count, version,
/// fingerprint and image, each finished, none twice, none missing.
/// Returns the first part's header.
fn check_belong<'a>(paths: &[PathBuf], headers: &'a [PartHeader]) -> Result<&'a PartHeader> {
    let (first, first_path) = (&headers[0], &paths[0]);
    let name = |p: &Path| p.display().to_string();
    let mut problems = Vec::new();
    for (path, h) in paths.iter().zip(headers) {
        if h.version != first.version {
            problems.push(format!(
                "{} was rendered by yubin {}, {} by yubin {}",
                name(path),
                h.version,
                name(first_path),
                first.version
            ));
        }
        if h.count != first.count {
            problems.push(format!(
                "{} is part {}/{}, {} is one of {}",
                name(path),
                h.index,
                h.count,
                name(first_path),
                first.count
            ));
        }
        let here = name(path);
        let there = name(first_path);
        let differences = differences(
            &h.fingerprint,
            &first.fingerprint,
            (&format!("in {here}"), &format!("in {there}")),
        );
        if !differences.is_empty() {
            problems.push(format!(
                "{here} and {there} differ in {}",
                differences.join("; ")
            ));
        }
        let same_image = (h.crop, h.crop_offset, h.margin, h.channels, &h.layers)
            == (
                first.crop,
                first.crop_offset,
                first.margin,
                first.channels,
                &first.layers,
            );
        if differences.is_empty() && !same_image {
            problems.push(format!(
                "{} is of another image than {}",
                name(path),
                name(first_path)
            ));
        }
        if h.done != h.spp {
            problems.push(format!(
                "{} is unfinished ({} of {} samples per pixel)",
                name(path),
                h.done,
                h.spp
            ));
        }
    }
    if !problems.is_empty() {
        bail!(
            "these parts do not belong together:\n  {}",
            problems.join("\n  ")
        );
    }
    let mut by_index: BTreeMap<u32, Vec<&Path>> = BTreeMap::new();
    for (path, h) in paths.iter().zip(headers) {
        by_index.entry(h.index).or_default().push(path);
    }
    for (index, files) in &by_index {
        if files.len() > 1 {
            let files: Vec<String> = files.iter().map(|p| name(p)).collect();
            problems.push(format!(
                "part {index}/{} is given {} times: {}",
                first.count,
                files.len(),
                files.join(", ")
            ));
        }
    }
    let missing: Vec<String> = (0..first.count)
        .filter(|k| !by_index.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        problems.push(format!(
            "part{} {} of {} missing",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            first.count,
        ));
    }
    if !problems.is_empty() {
        bail!("{}; nothing written", problems.join("; "));
    }
    Ok(first)
}

/// The render's output from the assembled `sums` and what the parts
/// counted: its non-finite samples listed in the order one render meets
/// them (by pass, then tile).
fn output_of(first: &PartHeader, headers: &[PartHeader], sums: &[f32]) -> RenderOutput {
    let passes = PassSize::growing(first.spp);
    let columns = first.crop[0].div_ceil(TILE_SIZE);
    let order = |s: &NonFiniteSample| {
        let x = s.x.saturating_sub(first.crop_offset[0]);
        let y = s.y.saturating_sub(first.crop_offset[1]);
        let tile = (y / TILE_SIZE) * columns + x / TILE_SIZE;
        (passes.pass_of_sample(s.index), tile)
    };
    let mut nonfinite: Vec<NonFiniteSample> =
        headers.iter().flat_map(|h| h.nonfinite.clone()).collect();
    nonfinite.sort_by_key(order);
    nonfinite.truncate(NONFINITE_KEPT);
    let (error_sum, error_count) = headers
        .iter()
        .fold((0.0, 0), |(s, c), h| (s + h.error.0, c + h.error.1));
    RenderOutput {
        image: Framebuffer {
            width: first.crop[0],
            height: first.crop[1],
            channels: first.channels,
            data: average(sums, first.channels),
        },
        layers: first.layers.clone(),
        dropped_samples: headers.iter().map(|h| h.dropped).sum(),
        nonfinite: NonFinite {
            pixels: headers.iter().map(|h| h.nonfinite_pixels).sum(),
            first: nonfinite,
        },
        samples: headers.iter().map(|h| h.samples).sum(),
        estimated_error: (error_count > 0).then(|| (error_sum / error_count as f64) as f32),
    }
}
