//! The same seed gives a bit-identical image on 1, 2 and 4 threads, and a
//! different seed gives a different one, with every sampler.

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::{load_scene, load_scene_str};

fn render_with_threads(threads: usize, seed: u32, sampler: &str) -> Vec<f32> {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [
        ("resx".to_string(), "40".to_string()),
        ("resy".to_string(), "24".to_string()),
    ];
    let mut loaded = load_scene(&scene, &defines).unwrap();
    let sampler_xml = format!(
        r#"<scene version="3.0.0"><sensor type="perspective"><sampler type="{sampler}">
             <integer name="sample_count" value="4"/></sampler></sensor></scene>"#
    );
    loaded.scene.sampler = load_scene_str(&sampler_xml, Path::new("sampler.xml"), &[])
        .unwrap()
        .scene
        .sampler;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let out = pool.install(|| {
        render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 4, seed },
            &|_| {},
        )
    });
    out.image.data
}

#[test]
fn same_seed_same_image_on_any_thread_count() {
    for (sampler, _) in yubin_core::sampler::PLUGINS {
        let one = render_with_threads(1, 3, sampler);
        for threads in [2, 4] {
            let many = render_with_threads(threads, 3, sampler);
            let identical = one
                .iter()
                .zip(&many)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(identical, "{sampler}: 1 and {threads} threads differ");
        }
        assert_ne!(
            one,
            render_with_threads(2, 4, sampler),
            "{sampler}: the seed must change the image"
        );
    }
}

/// A progressive render (passes of 2 samples per pixel, a Gaussian filter
/// whose splats cross tiles) gives the bit-identical image after each of
/// its first three passes on 1, 2 and 4 threads; the first pass changes
/// nothing already there and the second adds to it.
#[test]
fn progressive_passes_are_identical_on_any_thread_count() {
    use yubin_core::render::Progressive;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [
        ("resx".to_string(), "40".to_string()),
        ("resy".to_string(), "24".to_string()),
        ("rfilter".to_string(), "gaussian".to_string()),
    ];
    let loaded = load_scene(&scene, &defines).unwrap();
    let passes = |threads: usize| -> Vec<Vec<f32>> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let settings = RenderSettings { spp: 8, seed: 1 };
        let mut render = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 2);
        (0..3)
            .map(|_| {
                pool.install(|| render.pass(&|_| {}));
                render.output().image.data
            })
            .collect()
    };
    let one = passes(1);
    for threads in [2, 4] {
        let many = passes(threads);
        for (k, (a, b)) in one.iter().zip(&many).enumerate() {
            assert!(
                a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "pass {k}: 1 and {threads} threads differ"
            );
        }
    }
    assert_ne!(one[0], one[1], "a pass must add samples");
    // `render` of 3 samples per pixel takes passes of 1 and 2 (growing).
    let settings = RenderSettings { spp: 3, seed: 1 };
    let whole = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &settings,
        &|_| {},
    );
    let mut first = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 1);
    first.pass(&|_| {});
    let mut by_hand = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 2);
    by_hand.restore(first.state()).unwrap();
    by_hand.pass(&|_| {});
    assert!(by_hand.finished());
    assert_eq!(whole.image.data, by_hand.output().image.data);
}

/// Adaptive sampling is deterministic (the same image and `spp` layer on
/// 1, 2 and 4 threads), stops some pixels before the maximum, keeps every
/// pixel at the minimum at least, and reports the counts in its layer.
#[test]
fn adaptive_sampling_is_identical_on_any_thread_count() {
    use yubin_core::render::{Adaptive, Progressive};
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [
        ("resx".to_string(), "32".to_string()),
        ("resy".to_string(), "24".to_string()),
    ];
    let loaded = load_scene(&scene, &defines).unwrap();
    let adaptive = Adaptive {
        threshold: 0.1,
        min_spp: 8,
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let settings = RenderSettings { spp: 128, seed: 2 };
        let mut render = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 4)
            .with_adaptive(adaptive);
        while !render.finished() {
            pool.install(|| render.pass(&|_| {}));
        }
        render.output()
    };
    let one = run(1);
    assert_eq!(one.layers.last().map(|l| l.name.as_str()), Some("spp"));
    let counts: Vec<f32> = one
        .image
        .data
        .chunks_exact(one.image.channels)
        .map(|px| px[px.len() - 1])
        .collect();
    assert!(
        counts.iter().all(|n| (8.0..=128.0).contains(n)),
        "{counts:?}"
    );
    assert!(counts.iter().any(|&n| n < 128.0), "no pixel stopped");
    assert!(
        counts.iter().any(|&n| n > 8.0),
        "every pixel stopped at the minimum"
    );
    for threads in [2, 4] {
        let many = run(threads);
        assert!(
            one.image
                .data
                .iter()
                .zip(&many.image.data)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "1 and {threads} threads differ"
        );
    }
}

/// A render split into parts (each part's tiles rendered alone, on its own
/// thread count) and put together with `assemble` is the plain render's
/// image bit for bit: with a Gaussian filter whose splats cross tiles, an
/// image whose edge tiles are partial, 1 to 7 parts, and passes that grow.
#[test]
fn parts_assembled_equal_the_whole_render() {
    use yubin_core::render::{assemble, average, Part, PassSize, Progressive};
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [
        ("resx".to_string(), "53".to_string()),
        ("resy".to_string(), "37".to_string()),
        ("rfilter".to_string(), "gaussian".to_string()),
    ];
    let loaded = load_scene(&scene, &defines).unwrap();
    let settings = RenderSettings { spp: 21, seed: 5 };
    let whole = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &settings,
        &|_| {},
    );
    for count in 1..=7 {
        let parts: Vec<Progressive> = (0..count)
            .map(|index| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(1 + index as usize % 3)
                    .build()
                    .unwrap();
                let mut part =
                    Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 1)
                        .with_passes(PassSize::growing(settings.spp))
                        .with_part(Part { index, count })
                        .unwrap();
                while !part.finished() {
                    pool.install(|| part.pass(&|_| {}));
                }
                part
            })
            .collect();
        let mut tiles: Vec<(usize, &[f32])> = parts.iter().flat_map(|p| p.part_sums()).collect();
        tiles.sort_by_key(|&(i, _)| i);
        let margin = parts[0].margin();
        let sums = assemble(
            loaded.scene.film.crop_size,
            margin,
            3,
            tiles.iter().map(|&(_, t)| t),
        )
        .unwrap();
        let image = average(&sums, 3);
        let identical = image.len() == whole.image.data.len()
            && image
                .iter()
                .zip(&whole.image.data)
                .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(identical, "{count} parts differ from the whole render");
        let samples: u64 = parts.iter().map(|p| p.total_samples()).sum();
        assert_eq!(samples, whole.samples, "{count} parts");
        // A tile left out, or one of the wrong length, is refused.
        let short = assemble(
            loaded.scene.film.crop_size,
            margin,
            3,
            tiles[1..].iter().map(|&(_, t)| t),
        );
        assert!(short.is_err());
        let wrong = assemble(
            loaded.scene.film.crop_size,
            margin + 1,
            3,
            tiles.iter().map(|&(_, t)| t),
        );
        assert!(wrong.is_err());
    }
    // The film's 4 × 3 tiles make at most 12 parts.
    let too_many = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), settings, 1)
        .with_part(Part {
            index: 0,
            count: 13,
        });
    assert!(too_many.is_err());
}
