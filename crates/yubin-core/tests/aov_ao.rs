//! `aov` and `ao` on scenes with known answers: the depth, position and
//! normal AOVs of a plane and a sphere, the nested integrator's layers,
//! thread-count independence, and ambient occlusion under a disc against
//! its closed form.

use glam::{Affine3A, Vec2, Vec3};
use yubin_core::bsdf::{Diffuse, Material, Plastic, TwoSided};
use yubin_core::camera::{Camera, FovAxis, Perspective};
use yubin_core::film::Film;
use yubin_core::filter::Filter;
use yubin_core::integrator::{AoIntegrator, AovIntegrator, Integrator, Layer, PathIntegrator};
use yubin_core::math::{Ray, Transform};
use yubin_core::render::{render, RenderOutput, RenderScene, RenderSettings, RenderState};
use yubin_core::sampler::{Independent, Sampler};
use yubin_core::shape::{Disk, Rectangle, Shape, Sphere};
use yubin_core::{Rgb, Scene, SceneBuilder};

const RES: u32 = 16;
const HEIGHT: f32 = 3.0;
const NEAR: f32 = 0.01;

/// A `res`×`res` camera at height `HEIGHT` looking straight down (40°
/// field of view, box filter) with `spp` independent samples.
fn look_down(b: &mut SceneBuilder, res: u32, spp: u32) {
    let to_world = Affine3A::from_translation(Vec3::new(0.0, 0.0, HEIGHT))
        * Affine3A::from_rotation_x(std::f32::consts::PI);
    b.camera(Camera::Perspective(Perspective::new(
        to_world,
        40.0,
        FovAxis::X,
        res,
        res,
        NEAR,
        100.0,
    )));
    b.film(Film::new(res, res, Filter::Box));
    b.sampler(Sampler::Independent(Independent { sample_count: spp }));
}

/// A diffuse plane z = 0 (or nothing) and optionally a sphere, seen by a
/// camera at height `HEIGHT` looking straight down.
fn scene(plane: bool, sphere: Option<(Vec3, f32)>) -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::new(0.2, 0.4, 0.6))));
    if plane {
        let big = Transform::new(Affine3A::from_scale(Vec3::splat(50.0))).unwrap();
        b.add_shape(
            Shape::Rectangle(Rectangle::new(big, false)),
            Some(grey),
            None,
        )
        .unwrap();
    }
    if let Some((c, r)) = sphere {
        b.add_shape(Shape::Sphere(Sphere::new(c, r, false)), Some(grey), None)
            .unwrap();
    }
    look_down(&mut b, RES, 4);
    b.build().unwrap()
}

fn run(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> RenderOutput {
    render(scene, integrator, &RenderSettings { spp, seed: 7 }, &|_| {})
}

/// The first channel of layer `name` in the output.
fn offset_of(out: &RenderOutput, name: &str) -> usize {
    let mut o = 3;
    for l in &out.layers {
        if l.name == name {
            return o;
        }
        o += l.width();
    }
    panic!("no layer {name} in {:?}", out.layers);
}

fn aov(spec: &str, nested: Vec<(String, Box<dyn Integrator>)>) -> AovIntegrator {
    AovIntegrator::new(yubin_core::integrator::parse_aovs(spec).unwrap(), nested)
}

#[test]
fn aov_depth_position_and_normal_of_a_plane() {
    let scene = scene(true, None);
    let integrator = aov(
        "dd:depth, p:position, n:geo_normal, s:sh_normal, a:albedo",
        Vec::new(),
    );
    // Enough samples that the pixel mean of the depth (which varies by
    // ~2 % across a corner pixel) is within 5e-4 of its centre value.
    let out = run(&scene, &integrator, 256);
    assert_eq!(out.image.channels, 3 + 1 + 3 + 3 + 3 + 3);
    let (dd, p, n, s, a) = (
        offset_of(&out, "dd"),
        offset_of(&out, "p"),
        offset_of(&out, "n"),
        offset_of(&out, "s"),
        offset_of(&out, "a"),
    );
    for y in 0..RES {
        for x in 0..RES {
            let get = |c: usize| out.image.get(x, y, c);
            // Distance along the ray through the pixel centre from the
            // near-clip plane (as Mitsuba's rays start there):
            // (HEIGHT − near) / cos θ.
            let ray = scene
                .camera
                .generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), Vec2::splat(0.5))
                .unwrap();
            let expected = (HEIGHT - NEAR) / ray.d.normalize().z.abs();
            assert!(
                (get(dd) - expected).abs() < 2e-3 * expected,
                "depth at ({x},{y}) is {}, expected {expected}",
                get(dd)
            );
            // The mean hit point lies on the plane, under the pixel.
            assert!(get(p + 2).abs() < 1e-5, "position z {}", get(p + 2));
            let under = ray.o + ray.d.normalize() * HEIGHT / ray.d.normalize().z.abs();
            assert!((get(p) - under.x).abs() < 2e-2 && (get(p + 1) - under.y).abs() < 2e-2);
            for c in 0..3 {
                let up = [0.0, 0.0, 1.0][c];
                assert!((get(n + c) - up).abs() < 1e-6 && (get(s + c) - up).abs() < 1e-6);
                // Albedo of a diffuse surface is its reflectance.
                let rho = [0.2, 0.4, 0.6][c];
                assert!((get(a + c) - rho).abs() < 1e-5, "albedo {}", get(a + c));
            }
            // No nested integrator: the main RGB is zero.
            assert_eq!((get(0), get(1), get(2)), (0.0, 0.0, 0.0));
        }
    }
}

#[test]
fn aov_albedo_is_the_diffuse_parameter_as_in_mitsuba() {
    // A plastic plane (two-sided, seen from below) and a plastic sphere:
    // Mitsuba's albedo is the diffuse reflectance, not π · f (which has the
    // Fresnel and internal-reflection factors in it).
    let rho = Rgb::new(0.5, 0.5, 0.12);
    for two_sided in [false, true] {
        let mut b = SceneBuilder::new();
        let plastic = b.add_bsdf(Material::Plastic(Plastic::new(rho, 1.9, false)));
        let bsdf = if two_sided {
            b.add_bsdf(Material::TwoSided(TwoSided {
                front: plastic,
                back: plastic,
            }))
        } else {
            plastic
        };
        let big = Transform::new(Affine3A::from_scale(Vec3::splat(50.0))).unwrap();
        b.add_shape(
            // Seen from its back when two-sided.
            Shape::Rectangle(Rectangle::new(big, two_sided)),
            Some(bsdf),
            None,
        )
        .unwrap();
        look_down(&mut b, 4, 1);
        let scene = b.build().unwrap();
        let out = run(&scene, &aov("a:albedo", Vec::new()), 2);
        let a = offset_of(&out, "a");
        for px in out.image.data.chunks_exact(out.image.channels) {
            let got = Rgb::new(px[a], px[a + 1], px[a + 2]);
            assert!(
                (got - rho).abs().max_element() < 1e-6,
                "{got} two-sided {two_sided}"
            );
        }
    }
}

#[test]
fn aov_normal_of_a_sphere_and_zero_for_misses() {
    let (c, r) = (Vec3::new(0.0, 0.0, 0.5), 0.5);
    let scene = scene(false, Some((c, r)));
    let nested: Vec<(String, Box<dyn Integrator>)> =
        vec![("image".into(), Box::new(PathIntegrator::default()))];
    let integrator = aov("dd:depth, nn:sh_normal, pos:position", nested);
    let out = run(&scene, &integrator, 16);
    let names: Vec<&Layer> = out.layers.iter().collect();
    assert_eq!(names[0], &Layer::new("image", &["R", "G", "B", "A"]));
    let (img, dd, nn, pos) = (
        offset_of(&out, "image"),
        offset_of(&out, "dd"),
        offset_of(&out, "nn"),
        offset_of(&out, "pos"),
    );
    let mut covered = 0;
    for y in 0..RES {
        for x in 0..RES {
            let get = |ch: usize| out.image.get(x, y, ch);
            let n = Vec3::new(get(nn), get(nn + 1), get(nn + 2));
            let p = Vec3::new(get(pos), get(pos + 1), get(pos + 2));
            let alpha = get(img + 3);
            if alpha == 0.0 {
                // Missed everything: every AOV is zero.
                assert_eq!((n, p, get(dd)), (Vec3::ZERO, Vec3::ZERO, 0.0));
            }
            if alpha == 1.0 {
                // Fully covered: the normal is linear in the hit point, so
                // their pixel means agree exactly as the normal's definition.
                covered += 1;
                let expected = (p - c) / r;
                assert!(
                    (n - expected).length() < 1e-3,
                    "normal {n} at ({x},{y}), expected {expected}"
                );
            }
        }
    }
    assert!(covered > 20, "only {covered} pixels fully on the sphere");
    // The four pixels at the centre look (almost) straight down at the top
    // of the sphere: their centres are half a pixel (0.13 r) off the axis.
    let mid = RES / 2;
    let mut n_sum = Vec3::ZERO;
    for (x, y) in [
        (mid - 1, mid - 1),
        (mid, mid - 1),
        (mid - 1, mid),
        (mid, mid),
    ] {
        let n = Vec3::new(
            out.image.get(x, y, nn),
            out.image.get(x, y, nn + 1),
            out.image.get(x, y, nn + 2),
        );
        assert!(n.z > 0.98, "n at ({x},{y}) is {n}");
        n_sum += n;
        let d = out.image.get(x, y, dd);
        assert!((d - (HEIGHT - 2.0 * r - NEAR)).abs() < 0.01, "depth {d}");
    }
    // Symmetric about the axis up to the noise of 16 random film offsets
    // per pixel: each pixel's mean offset has σ = 0.29 / 4 pixel, a pixel
    // is 0.26 r, so each component of the sum has σ ≈ 2 · 0.26 · 0.072 =
    // 0.04. A half-pixel shift of the AOV would put 0.5 there.
    assert!(n_sum.x.abs() < 0.15 && n_sum.y.abs() < 0.15, "{n_sum}");
    // The main RGB is the nested path tracer's.
    for px in 0..(RES * RES) as usize {
        let v = &out.image.data[px * out.image.channels..];
        assert_eq!(&v[0..3], &v[img..img + 3]);
    }
}

#[test]
fn aov_images_do_not_depend_on_thread_count() {
    let scene = scene(true, Some((Vec3::new(0.3, 0.0, 0.5), 0.5)));
    let nested: Vec<(String, Box<dyn Integrator>)> =
        vec![("image".into(), Box::new(PathIntegrator::default()))];
    let integrator = aov("dd:depth, uv:uv, i:shape_index, a:albedo", nested);
    let with = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&scene, &integrator, 4))
    };
    let (one, four) = (with(1), with(4));
    let bits = |o: &RenderOutput| o.image.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&four));
    assert_eq!(one.layers, four.layers);
}

/// A floor z = 0 and a disc of radius `radius` at height `h` over the
/// origin, for ambient occlusion at the origin.
fn disc_scene(radius: f32, h: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::splat(0.5))));
    let floor = Transform::new(Affine3A::from_scale(Vec3::splat(20.0))).unwrap();
    b.add_shape(
        Shape::Rectangle(Rectangle::new(floor, false)),
        Some(grey),
        None,
    )
    .unwrap();
    let disc = Affine3A::from_translation(Vec3::new(0.0, 0.0, h))
        * Affine3A::from_scale(Vec3::splat(radius));
    b.add_shape(
        Shape::Disk(Disk::new(Transform::new(disc).unwrap(), true)),
        Some(grey),
        None,
    )
    .unwrap();
    b.build().unwrap()
}

/// Mean and standard error of ao at the origin over `n` camera samples.
fn ao_at_origin(scene: &Scene, ao: &AoIntegrator, n: u32) -> (f64, f64) {
    // From the side, below the disc, towards the origin.
    let o = Vec3::new(3.0, 0.0, 0.25);
    let ray = Ray::new(o, (Vec3::ZERO - o).normalize());
    let state = RenderState::new(scene, ao);
    let render = RenderScene::new(scene, &state);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let mut stream = scene.sampler.stream(i % 64, i / 64, i, 11);
        let v = f64::from(ao.li(&render, &ray, &mut stream).x);
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / f64::from(n);
    let var = (sum2 / f64::from(n) - mean * mean).max(0.0);
    (mean, (var / f64::from(n)).sqrt())
}

#[test]
fn ao_under_a_disc_matches_the_closed_form() {
    // Cosine-weighted visibility under a disc of angular radius θ straight
    // above: 1 − sin²θ = h² / (R² + h²).
    for &(radius, h) in &[(1.0f32, 1.0f32), (2.0, 1.0), (0.5, 1.5)] {
        let scene = disc_scene(radius, h);
        let expected = f64::from(h * h / (radius * radius + h * h));
        for samples in [1, 8] {
            let ao = AoIntegrator {
                shading_samples: samples,
                max_distance: None,
            };
            let (mean, se) = ao_at_origin(&scene, &ao, 20_000);
            assert!(
                (mean - expected).abs() < 4.0 * se + 1e-4,
                "R {radius} h {h} samples {samples}: {mean} ± {se}, expected {expected}"
            );
        }
    }
}

#[test]
fn ao_max_distance_ignores_far_occluders() {
    let scene = disc_scene(1.0, 1.0);
    // Every ray to the disc is at least 1 long.
    let short = AoIntegrator {
        shading_samples: 4,
        max_distance: Some(0.9),
    };
    let (mean, se) = ao_at_origin(&scene, &short, 2_000);
    assert_eq!((mean, se), (1.0, 0.0));
    // Rays shorter than 1.2 reach the disc when cos θ > 1/1.2 (and then
    // hit it: tan θ < 1): occluded fraction sin²θ₁ = 1 − 1/1.44.
    let mid = AoIntegrator {
        shading_samples: 1,
        max_distance: Some(1.2),
    };
    let expected = 1.0 / 1.44;
    let (mean, se) = ao_at_origin(&scene, &mid, 20_000);
    assert!(
        (mean - expected).abs() < 4.0 * se,
        "{mean} ± {se}, expected {expected}"
    );
}

#[test]
fn ao_is_zero_for_camera_rays_that_miss() {
    let scene = disc_scene(1.0, 1.0);
    let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::Z);
    let mut stream = scene.sampler.stream(0, 0, 0, 0);
    let ao = AoIntegrator::default();
    let state = RenderState::new(&scene, &ao);
    let render = RenderScene::new(&scene, &state);
    assert_eq!(ao.li(&render, &ray, &mut stream), Rgb::ZERO);
}
