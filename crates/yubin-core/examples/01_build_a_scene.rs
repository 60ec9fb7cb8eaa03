//! Example 1: build a scene in code and render it with the path tracer.
//! The README shows this file's code below this header, and
//! `cargo test --doc -p yubin-core` compiles and runs the README's copy
//! (`ReadmeDoctests` in `src/lib.rs`): keep the two the same.
//! Run: `cargo run --release -p yubin-core --example 01_build_a_scene`.

use std::f32::consts::FRAC_PI_2;
use yubin_core::bsdf::{Diffuse, Material};
use yubin_core::camera::{Camera, FovAxis, Perspective};
use yubin_core::film::Film;
use yubin_core::filter::Filter;
use yubin_core::integrator::PathIntegrator;
use yubin_core::light::{Emitter, PointLight};
use yubin_core::math::Transform;
use yubin_core::render::{render, RenderSettings};
use yubin_core::sampler::{Sampler, Sobol};
use yubin_core::shape::{Rectangle, Shape, Sphere};
use yubin_core::{Affine3A, Rgb, SceneBuilder, Vec3};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sb = SceneBuilder::new();
    let grey = sb.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::splat(0.7))));
    let red = sb.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::new(0.8, 0.1, 0.1))));

    // A 20×20 floor: the rectangle [-1, 1]² facing +z, turned to face +y.
    let floor = Affine3A::from_rotation_x(-FRAC_PI_2) * Affine3A::from_scale(Vec3::splat(10.0));
    let floor = Transform::new(floor).expect("invertible");
    sb.add_shape(
        Shape::Rectangle(Rectangle::new(floor, false)),
        Some(grey),
        None,
    )?;
    sb.add_shape(
        Shape::Sphere(Sphere::new(Vec3::new(0.0, 1.0, 0.0), 1.0, false)),
        Some(red),
        None,
    )?;
    // An emissive sphere (area light): the last argument is its radiance.
    sb.add_shape(
        Shape::Sphere(Sphere::new(Vec3::new(3.0, 4.0, -2.0), 0.5, false)),
        None,
        Some(Rgb::splat(20.0).into()),
    )?;
    sb.add_emitter(Emitter::Point(PointLight {
        position: Vec3::new(-3.0, 5.0, -3.0),
        intensity: Rgb::splat(15.0),
    }));

    // Mitsuba's camera convention: looking down +z, +y up.
    let (w, h) = (64, 48);
    sb.camera(Camera::Perspective(Perspective::new(
        Affine3A::from_translation(Vec3::new(0.0, 1.5, -7.0)),
        45.0,
        FovAxis::X,
        w,
        h,
        0.01,
        1e4,
    )))
    .film(Film::new(w, h, Filter::Tent { radius: 1.0 }))
    .sampler(Sampler::Sobol(Sobol { sample_count: 4 }));
    let scene = sb.build()?;

    let settings = RenderSettings { spp: 4, seed: 0 };
    let out = render(
        &scene,
        &PathIntegrator::default(),
        &settings,
        &|_samples_done| {},
    );
    let rgb = out.image.select_channels(0..3); // interleaved linear RGB, top row first
    println!(
        "{}×{}, centre pixel {}",
        rgb.width,
        rgb.height,
        rgb.get(w / 2, h / 2, 0)
    );
    Ok(())
}
