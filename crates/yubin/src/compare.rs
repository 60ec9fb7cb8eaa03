//! `yubin compare`: error metrics of an image against a reference.
//!
//! - relMSE = mean over pixels and channels of (a − b)² / (b² + 0.01)
//! - RMSE = √(mean of (a − b)²)
//! - bias = (mean luminance of a − mean luminance of b) / mean luminance of b

use anyhow::{bail, Result};
use std::path::PathBuf;
use yubin_scene::image_io::{read_image, ColorHandling, Image};

/// Arguments of `yubin compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The image to judge.
    image: PathBuf,
    /// The reference.
    reference: PathBuf,
}

/// Error metrics of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Relative mean squared error.
    pub rel_mse: f64,
    /// Root mean squared error.
    pub rmse: f64,
    /// Relative difference of mean luminance.
    pub luminance_bias: f64,
}

/// Computes [`Metrics`] over the first three channels of two images of the
/// same size.
pub fn metrics(a: &Image, b: &Image) -> Result<Metrics> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "image sizes differ: {}x{} vs {}x{}",
            a.width,
            a.height,
            b.width,
            b.height
        );
    }
    if a.channels < 3 || b.channels < 3 {
        bail!("both images need at least three channels");
    }
    let (mut rel, mut sq, mut lum_a, mut lum_b) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let n = a.width * a.height;
    for i in 0..n {
        let pa = &a.data[i * a.channels..i * a.channels + 3];
        let pb = &b.data[i * b.channels..i * b.channels + 3];
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            let d2 = (x - y) * (x - y);
            rel += d2 / (y * y + 0.01);
            sq += d2;
        }
        lum_a += luminance(pa);
        lum_b += luminance(pb);
    }
    let count = (3 * n).max(1) as f64;
    Ok(Metrics {
        rel_mse: rel / count,
        rmse: (sq / count).sqrt(),
        luminance_bias: (lum_a - lum_b) / lum_b,
    })
}

fn luminance(p: &[f32]) -> f64 {
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

/// Prints the metrics.
pub fn run(args: CompareArgs) -> Result<()> {
    let a = read_image(&args.image, ColorHandling::Srgb)?;
    let b = read_image(&args.reference, ColorHandling::Srgb)?;
    let m = metrics(&a, &b)?;
    report(&mut std::io::stdout().lock(), &m)
}

/// Prints `m` to `out`; a reader that stopped early (`| head -1`) is not
/// an error.
fn report(out: &mut impl std::io::Write, m: &Metrics) -> Result<()> {
    match print_metrics(out, m) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        result => Ok(result?),
    }
}

fn print_metrics(out: &mut impl std::io::Write, m: &Metrics) -> std::io::Result<()> {
    writeln!(out, "relMSE {:.6}", m.rel_mse)?;
    writeln!(out, "RMSE   {:.6}", m.rmse)?;
    writeln!(
        out,
        "bias   {:+.4}% (mean luminance)",
        m.luminance_bias * 100.0
    )?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer whose reader is gone (or that fails otherwise).
    struct Failing(std::io::ErrorKind);

    impl std::io::Write for Failing {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(self.0.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// `yubin compare a b | head -1` ends quietly; other write errors
    /// are reported.
    #[test]
    fn a_closed_pipe_is_not_an_error() {
        let m = Metrics {
            rel_mse: 0.5,
            rmse: 0.1,
            luminance_bias: 0.0,
        };
        assert!(report(&mut Failing(std::io::ErrorKind::BrokenPipe), &m).is_ok());
        assert!(report(&mut Failing(std::io::ErrorKind::StorageFull), &m).is_err());
        let mut text = Vec::new();
        report(&mut text, &m).unwrap();
        assert!(String::from_utf8(text)
            .unwrap()
            .starts_with("relMSE 0.500000\n"));
    }

    #[test]
    fn metrics_of_known_images() {
        let b = Image {
            width: 2,
            height: 1,
            channels: 3,
            data: vec![1.0; 6],
        };
        let a = Image {
            width: 2,
            height: 1,
            channels: 3,
            data: vec![1.1; 6],
        };
        let m = metrics(&a, &b).unwrap();
        assert!((m.rmse - 0.1).abs() < 1e-6);
        assert!((m.rel_mse - 0.01 / 1.01).abs() < 1e-6);
        assert!((m.luminance_bias - 0.1).abs() < 1e-6);
        assert!(metrics(
            &a,
            &Image {
                width: 1,
                height: 1,
                channels: 3,
                data: vec![1.0; 3]
            }
        )
        .is_err());
    }
}
