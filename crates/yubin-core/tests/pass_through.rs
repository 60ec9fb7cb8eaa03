//! Surfaces that let light through (`null`, `mask`) in the path tracer:
//! shadow rays see through them with their transmittance, crossings count
//! as bounces against `max_depth` (as Mitsuba's integrators count them),
//! and light reached through them is neither lost nor counted twice by
//! multiple importance sampling.
//!
//! The scene: a black-backed diffuse floor lit from above, with a sheet
//! between light and floor that the camera does not see.

use glam::{Affine3A, Vec3};
use yubin_core::bsdf::{Diffuse, Mask, Material, Null};
use yubin_core::camera::{Camera, FovAxis, Perspective};
use yubin_core::film::Film;
use yubin_core::filter::Filter;
use yubin_core::integrator::PathIntegrator;
use yubin_core::light::{Emitter, PointLight};
use yubin_core::math::Transform;
use yubin_core::render::{render, RenderSettings};
use yubin_core::sampler::{Independent, Sampler};
use yubin_core::shape::{Rectangle, Shape, Sphere};
use yubin_core::texture::Tex;
use yubin_core::{Rgb, SceneBuilder};

#[derive(Clone, Copy)]
enum Sheet {
    None,
    Null,
    /// A mask of this opacity over black diffuse (so it reflects nothing).
    Mask(f32),
}

#[derive(Clone, Copy)]
enum Light {
    Point,
    /// A small emitting sphere (reachable by BSDF sampling too).
    Sphere,
}

/// Mean radiance of the floor seen from above.
fn render_mean(sheet: Sheet, light: Light, max_depth: i32, spp: u32) -> f32 {
    let mut b = SceneBuilder::new();
    let floor = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::splat(0.5))));
    // The floor: the rectangle [-1, 1]² at z = 0, facing +z.
    let big = Transform::new(Affine3A::from_scale(Vec3::splat(4.0))).unwrap();
    b.add_shape(
        Shape::Rectangle(Rectangle::new(big, false)),
        Some(floor),
        None,
    )
    .unwrap();
    let sheet_bsdf = match sheet {
        Sheet::None => None,
        Sheet::Null => Some(b.add_bsdf(Material::Null(Null))),
        Sheet::Mask(alpha) => {
            let black = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::ZERO)));
            Some(b.add_bsdf(Material::Mask(Mask {
                opacity: Tex::value(alpha),
                nested: black,
            })))
        }
    };
    if let Some(bsdf) = sheet_bsdf {
        // A sheet at z = 2 covering the light's view of the floor; the
        // camera looks through a hole-free part of space beside it.
        let t = Affine3A::from_translation(Vec3::new(0.0, 0.0, 2.0))
            * Affine3A::from_scale(Vec3::splat(20.0));
        b.add_shape(
            Shape::Rectangle(Rectangle::new(Transform::new(t).unwrap(), false)),
            Some(bsdf),
            None,
        )
        .unwrap();
    }
    let light_pos = Vec3::new(0.0, 0.0, 3.0);
    match light {
        Light::Point => {
            b.add_emitter(Emitter::Point(PointLight {
                position: light_pos,
                intensity: Rgb::splat(10.0),
            }));
        }
        Light::Sphere => {
            b.add_shape(
                Shape::Sphere(Sphere::new(light_pos, 0.3, false)),
                None,
                Some(Rgb::splat(10.0).into()),
            )
            .unwrap();
        }
    }
    // The camera sits below the sheet, looking straight down at the floor.
    let to_world = Affine3A::from_translation(Vec3::new(0.0, 0.0, 1.5))
        * Affine3A::from_rotation_x(std::f32::consts::PI);
    let res = 8;
    b.camera(Camera::Perspective(Perspective::new(
        to_world,
        30.0,
        FovAxis::X,
        res,
        res,
        0.01,
        100.0,
    )));
    b.film(Film::new(res, res, Filter::Box));
    b.sampler(Sampler::Independent(Independent { sample_count: spp }));
    let scene = b.build().unwrap();
    let integrator = PathIntegrator {
        max_depth,
        rr_depth: 100,
        ..Default::default()
    };
    let out = render(
        &scene,
        &integrator,
        &RenderSettings { spp, seed: 3 },
        &|_| {},
    );
    let rgb = out.image.select_channels(0..3);
    rgb.data.iter().sum::<f32>() / rgb.data.len() as f32
}

#[test]
fn shadow_rays_see_through_a_mask_with_its_transmittance() {
    let open = render_mean(Sheet::None, Light::Point, 3, 16);
    let masked = render_mean(Sheet::Mask(0.3), Light::Point, 3, 16);
    assert!(open > 0.01, "the floor is lit: {open}");
    let ratio = masked / open;
    assert!(
        (ratio - 0.7).abs() < 1e-3,
        "transmittance 0.7 expected, got {ratio}"
    );
}

#[test]
fn a_crossing_counts_as_a_bounce() {
    // max_depth 2 is direct light only: light that must cross the sheet
    // would need a third segment, so the floor is dark (as in Mitsuba).
    let masked = render_mean(Sheet::Mask(0.3), Light::Point, 2, 16);
    assert_eq!(masked, 0.0);
    assert!(render_mean(Sheet::None, Light::Point, 2, 16) > 0.01);
}

#[test]
fn a_null_sheet_is_invisible_to_light_reached_both_ways() {
    // An area light is reached by light sampling and by BSDF sampling;
    // through a null sheet the two must still add up to the open scene's
    // light (not twice it, not less).
    let spp = 256;
    let open = render_mean(Sheet::None, Light::Sphere, -1, spp);
    let behind_null = render_mean(Sheet::Null, Light::Sphere, -1, spp);
    let rel = (behind_null - open).abs() / open;
    assert!(rel < 0.02, "open {open}, behind a null sheet {behind_null}");
}
