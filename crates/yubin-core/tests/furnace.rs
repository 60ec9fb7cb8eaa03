//! White-furnace and analytic scenes whose answer is known.
//!
//! A convex diffuse object inside a uniform environment of radiance 1
//! reflects ρ·1 in every direction (each reflected ray escapes to the
//! environment), so an albedo-1 sphere vanishes into the background at any
//! path depth and an albedo-ρ sphere renders exactly ρ.

use glam::{Affine3A, Vec3};
use yubin_core::bsdf::{DiffTrans, Diffuse, Material, PrincipledThin};
use yubin_core::camera::{Camera, FovAxis, Perspective};
use yubin_core::film::Film;
use yubin_core::filter::Filter;
use yubin_core::integrator::{DirectIntegrator, Integrator, PathIntegrator};
use yubin_core::light::{ConstantLight, Emitter};
use yubin_core::render::{render, RenderSettings};
use yubin_core::sampler::{Independent, Sampler};
use yubin_core::shape::{Shape, Sphere};
use yubin_core::texture::Tex;
use yubin_core::{Rgb, Scene, SceneBuilder};

const RES: u32 = 16;

fn furnace(albedo: f32) -> Scene {
    furnace_with(Material::Diffuse(Diffuse::new(Rgb::splat(albedo))))
}

/// A unit sphere of `bsdf` inside a white environment, seen by a camera.
fn furnace_with(bsdf: Material) -> Scene {
    let mut b = SceneBuilder::new();
    let bsdf = b.add_bsdf(bsdf);
    b.add_shape(
        Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0, false)),
        Some(bsdf),
        None,
    )
    .unwrap();
    b.add_emitter(Emitter::Constant(ConstantLight { radiance: Rgb::ONE }));
    let eye = Affine3A::look_at_rh(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y).inverse();
    // look_at_rh looks down -z; Mitsuba cameras look down +z with +x left.
    let to_world = eye * Affine3A::from_scale(Vec3::new(-1.0, 1.0, -1.0));
    b.camera(Camera::Perspective(Perspective::new(
        to_world,
        40.0,
        FovAxis::X,
        RES,
        RES,
        0.01,
        100.0,
    )));
    b.film(Film::new(RES, RES, Filter::Box));
    b.sampler(Sampler::Independent(Independent { sample_count: 64 }));
    b.build().unwrap()
}

/// The path tracer with `max_depth`, light-sampling the environment
/// whole (no MIS compensation): light samples and BSDF samples both find
/// it, weighed by MIS.
fn path_uncompensated(max_depth: i32) -> PathIntegrator {
    PathIntegrator {
        max_depth,
        mis_compensation: false,
        ..Default::default()
    }
}

/// Renders and returns every pixel's RGB.
fn pixels(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> Vec<Rgb> {
    let out = render(scene, integrator, &RenderSettings { spp, seed: 7 }, &|_| {});
    out.image
        .data
        .chunks_exact(3)
        .map(|p| Rgb::new(p[0], p[1], p[2]))
        .collect()
}

fn assert_uniform(px: &[Rgb], expected: f32, tol_mean: f32, tol_pixel: f32, what: &str) {
    let mean = px.iter().copied().sum::<Rgb>() / px.len() as f32;
    assert!(
        (mean - Rgb::splat(expected)).abs().max_element() < tol_mean,
        "{what}: mean {mean}, expected {expected}"
    );
    for (i, p) in px.iter().enumerate() {
        assert!(
            (*p - Rgb::splat(expected)).abs().max_element() < tol_pixel,
            "{what}: pixel {i} is {p}, expected {expected}"
        );
    }
}

#[test]
fn white_furnace_path_tracer_renders_one_everywhere() {
    let scene = furnace(1.0);
    let path = path_uncompensated(64);
    assert_uniform(
        &pixels(&scene, &path, 256),
        1.0,
        0.005,
        0.08,
        "path, albedo 1",
    );
}

#[test]
fn grey_furnace_matches_albedo() {
    // Background pixels see the environment (1), sphere pixels see ρ: check
    // the sphere's centre region only.
    let scene = furnace(0.5);
    let path = path_uncompensated(64);
    let px = pixels(&scene, &path, 256);
    let centre: Vec<Rgb> = (6..10)
        .flat_map(|y| (6..10).map(move |x| (y * RES + x) as usize))
        .map(|i| px[i])
        .collect();
    assert_uniform(&centre, 0.5, 0.01, 0.05, "path, albedo 0.5");
}

/// Under MIS compensation the white environment is not light-sampled:
/// each path's one cosine-weighted BSDF sample escapes to it with the full
/// weight, so every pixel is ρ·1 exactly, without noise (light samples,
/// their MIS weights and the BSDF samples' weights below one would add
/// some), and the path tracer's default asks for it.
#[test]
fn compensated_furnaces_render_their_albedo_without_noise() {
    for albedo in [1.0, 0.5] {
        let scene = furnace(albedo);
        let path = PathIntegrator {
            max_depth: 64,
            ..Default::default()
        };
        assert!(path.mis_compensation());
        let px = pixels(&scene, &path, 16);
        let centre: Vec<Rgb> = (6..10)
            .flat_map(|y| (6..10).map(move |x| (y * RES + x) as usize))
            .map(|i| px[i])
            .collect();
        assert_uniform(&centre, albedo, 1e-5, 1e-5, "compensated path");
        assert_uniform(&px[..RES as usize], 1.0, 1e-5, 1e-5, "background");
    }
}

#[test]
fn white_furnace_direct_integrator() {
    // Direct lighting of a convex object is the whole answer.
    let scene = furnace(1.0);
    assert_uniform(
        &pixels(
            &scene,
            &DirectIntegrator {
                mis_compensation: false,
                ..Default::default()
            },
            256,
        ),
        1.0,
        0.005,
        0.08,
        "direct, albedo 1",
    );
}

#[test]
fn furnace_can_fail() {
    // A too-bright BSDF must be caught by the same check.
    let scene = furnace(1.1);
    let px = pixels(&scene, &path_uncompensated(2), 64);
    let mean = px.iter().copied().sum::<Rgb>() / px.len() as f32;
    assert!(mean.x > 1.02, "{mean}");
}

/// Lossless BSDFs that transmit, too, vanish in a white furnace: light
/// crosses the sphere any number of times and still comes out whole.
#[test]
fn transmitting_lossless_bsdfs_vanish_in_a_white_furnace() {
    let cases = [
        ("difftrans 1", Material::DiffTrans(DiffTrans::new(Rgb::ONE))),
        (
            "principledthin, diff_trans 2, white",
            Material::PrincipledThin(PrincipledThin {
                diff_trans: Tex::value(2.0),
                ..PrincipledThin::new(Rgb::ONE)
            }),
        ),
    ];
    let path = PathIntegrator {
        rr_depth: 1000,
        ..path_uncompensated(256)
    };
    for (what, bsdf) in cases {
        assert_uniform(
            &pixels(&furnace_with(bsdf), &path, 256),
            1.0,
            0.005,
            0.08,
            what,
        );
    }
}
