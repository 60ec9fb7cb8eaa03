//! Denoiser guides: the albedo, normal and depth layers that Intel Open
//! Image Denoise (and Blender's denoise node) take beside the noisy image,
//! added to any integrator's output by [`DenoiserGuides`] (`yubin render
//! --aov albedo,normal,depth`).
//!
//! As OIDN's documentation asks, albedo and normal are those of the first
//! hit that is not purely specular, and free of noise: a path from the
//! camera follows `dielectric`, `conductor` and other delta-only surfaces
//! (multiplying the albedo by what each passes on) and `null` surfaces,
//! always taking the last lobe a BSDF offers (transmission through glass
//! unless it reflects totally, the null lobe of a `mask`), so a glass
//! ball shows what lies behind it. Albedo is the BSDF's diffuse reflectance as
//! the `aov` integrator defines it (π f(wo, n) for models without a
//! diffuse colour); a ray that escapes takes the environment's radiance,
//! clamped to 1. Normals are the shading normals in world space (unit);
//! depth is the distance to the first hit along the camera ray (0 for a
//! miss). Every value is averaged over a pixel's samples through the
//! film's filter, like the image.

use super::{aov, environment_radiance, Integrator, Layer, RayOrigin};
use crate::bsdf::{BsdfContext, BsdfFlags};
use crate::math::Ray;
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::Rgb;
use glam::Vec3;

/// The most specular or null surfaces the guides follow.
const MAX_CHAIN: u32 = 16;

/// A guide layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Guide {
    /// `albedo.R,G,B`.
    Albedo,
    /// `normal.X,Y,Z`.
    Normal,
    /// `depth.Z`.
    Depth,
}

impl Guide {
    /// Every guide by name.
    pub const ALL: [(&'static str, Guide); 3] = [
        ("albedo", Guide::Albedo),
        ("normal", Guide::Normal),
        ("depth", Guide::Depth),
    ];

    /// The layer it writes.
    pub fn layer(self) -> Layer {
        match self {
            Guide::Albedo => Layer::new("albedo", &["R", "G", "B"]),
            Guide::Normal => Layer::new("normal", &["X", "Y", "Z"]),
            Guide::Depth => Layer::new("depth", &["Z"]),
        }
    }
}

/// An integrator with denoiser guide layers after its own.
#[derive(Debug)]
pub struct DenoiserGuides {
    inner: Box<dyn Integrator>,
    guides: Vec<Guide>,
}

/// What the camera ray finds for the guides.
struct FirstHit {
    albedo: Rgb,
    normal: Vec3,
    depth: f32,
}

impl DenoiserGuides {
    /// `inner` with the layers of `guides` (in that order) after its own.
    pub fn new(inner: Box<dyn Integrator>, guides: Vec<Guide>) -> Self {
        Self { inner, guides }
    }

    /// Follows the camera ray through specular and null surfaces to the
    /// first surface that is not purely specular.
    fn first_hit(scene: &RenderScene, camera_ray: &Ray) -> FirstHit {
        let ctx = BsdfContext::default();
        let mut ray = *camera_ray;
        let mut tint = Rgb::ONE;
        let mut depth = None;
        for _ in 0..MAX_CHAIN {
            let Some(si) = scene.intersect(&ray) else {
                let sky = environment_radiance(scene, &RayOrigin::camera(ray.o), ray.d.normalize());
                return FirstHit {
                    albedo: tint * sky.min(Rgb::ONE),
                    normal: Vec3::ZERO,
                    depth: depth.unwrap_or(0.0),
                };
            };
            let depth = *depth.get_or_insert((si.t - camera_ray.t_min) * camera_ray.d.length());
            let flags = scene.bsdf_flags_of(si.shape);
            if flags.intersects(BsdfFlags::SMOOTH) {
                return FirstHit {
                    albedo: tint * aov::albedo(scene, &si),
                    normal: si.sh_frame.n,
                    depth,
                };
            }
            let wo = si.to_local(si.wo);
            // The last lobe, the same every sample: guides without noise.
            let (u1, u2) = (1.0 - f32::EPSILON, glam::Vec2::splat(0.5));
            let bsdf = scene.bsdf_of(si.shape).at(&scene.materials, &si, wo);
            let Some(bs) = bsdf.sample(&ctx, u1, u2) else {
                return FirstHit {
                    albedo: Rgb::ZERO,
                    normal: si.sh_frame.n,
                    depth,
                };
            };
            tint *= bs.weight;
            ray = si.spawn_ray(si.to_world(bs.wi));
        }
        FirstHit {
            albedo: Rgb::ZERO,
            normal: Vec3::ZERO,
            depth: depth.unwrap_or(0.0),
        }
    }
}

impl Integrator for DenoiserGuides {
    fn extra_layers(&self) -> Vec<Layer> {
        let mut layers = self.inner.extra_layers();
        layers.extend(self.guides.iter().map(|g| g.layer()));
        layers
    }

    fn extra_channel_count(&self) -> usize {
        self.inner.extra_channel_count()
            + self
                .guides
                .iter()
                .map(|g| match g {
                    Guide::Depth => 1,
                    _ => 3,
                })
                .sum::<usize>()
    }

    fn light_selection(&self) -> Option<crate::light::LightSelection> {
        self.inner.light_selection()
    }

    fn reads_uv(&self) -> bool {
        self.inner.reads_uv()
    }

    fn mis_compensation(&self) -> bool {
        self.inner.mis_compensation()
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        self.inner.li(scene, ray, sampler)
    }

    fn sample(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream, out: &mut [f32]) {
        let n = self.inner.channel_count();
        self.inner.sample(scene, ray, sampler, &mut out[..n]);
        let hit = Self::first_hit(scene, ray);
        let mut at = n;
        for g in &self.guides {
            let values: &[f32] = match g {
                Guide::Albedo => &hit.albedo.to_array(),
                Guide::Normal => &hit.normal.to_array(),
                Guide::Depth => &[hit.depth],
            };
            out[at..at + values.len()].copy_from_slice(values);
            at += values.len();
        }
    }
}
