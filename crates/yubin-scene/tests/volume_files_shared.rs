//! Mitsuba's own `.vol` grids (its participating-media test scenes) read
//! as Mitsuba 3.9.1 reads them: resolution, channels, largest value, sum
//! and first values (from `mitsuba.VolumeGrid`).

mod common;

use glam::Vec3;
use yubin_scene::volume_io::read_vol;

#[test]
fn mitsuba_vol_files_match_mitsuba_shared() {
    let Some(shared) = common::shared_or_skip("mitsuba_vol_files_match_mitsuba_shared") else {
        return;
    };
    let dir = shared.join("mitsuba-data/tests/scenes/participating_media/textures");
    for (file, channels, max, sum, first) in [
        (
            "sigmat.vol",
            1,
            5.0,
            2495.1055,
            [0.420_735_5, 0.454_648_7, 0.070_56, 0.0],
        ),
        (
            "albedo.vol",
            3,
            1.0,
            4940.007,
            [1.0, 0.0, 0.360_216_2, 0.771_182_7],
        ),
    ] {
        let g = read_vol(&dir.join(file)).unwrap();
        assert_eq!((g.res, g.channels), ([16, 16, 16], channels), "{file}");
        assert_eq!(g.max(), max, "{file}");
        // Voxel values through the grid's lookup at voxel centres.
        let centre = |i: usize| {
            let b = &g.bounds;
            let size = b.max - b.min;
            let v = i / channels as usize;
            b.min + size * (Vec3::new(v as f32, 0.0, 0.0) + 0.5) / 16.0
        };
        for (i, want) in first.iter().enumerate() {
            let got = g.eval(centre(i))[i % channels as usize];
            assert!(
                (got - want).abs() < 1e-5,
                "{file} value {i}: {got} vs {want}"
            );
        }
        let mut total = 0.0f64;
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    let p = g.bounds.min
                        + (g.bounds.max - g.bounds.min)
                            * (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
                            / 16.0;
                    let v = g.eval(p);
                    total += (0..channels as usize).map(|c| v[c] as f64).sum::<f64>();
                }
            }
        }
        assert!(
            (total / sum - 1.0).abs() < 1e-4,
            "{file}: sum {total} vs {sum}"
        );
    }
}
