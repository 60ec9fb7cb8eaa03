//! `ptracer`: particle tracing. Paths start at the lights and every vertex
//! is connected to the camera (light tracing; Veach 1997, ch. 4 and 10;
//! Mitsuba 3's `ptracer`). It finds caustics the camera sees through
//! specular surfaces, which `path` can only reach by chance.
//!
//! | parameter          | type    | default | meaning                                                    |
//! |--------------------|---------|---------|------------------------------------------------------------|
//! | `max_depth`        | integer | -1      | longest path in segments (−1: unlimited); 1 = visible emitters only, 2 = direct light |
//! | `rr_depth`         | integer | 5       | Russian roulette starts once a light path has this many segments |
//! | `hide_emitters`    | boolean | false   | emitters seen directly by the camera render black          |
//! | `samples_per_pass` | integer | —       | accepted as Mitsuba does; yubin splits the work itself     |
//!
//! ```xml
//! <integrator type="ptracer"><integer name="max_depth" value="8"/></integrator>
//! ```
//!
//! A render traces spp × (crop pixels) light paths. Each path first
//! renders what the camera sees of the lights directly (unless
//! `hide_emitters`): it picks an emitter with the scene's light sampler as
//! seen from the camera, samples it from the camera's position and splats
//! L · importance / pdf where that direction lands; this is how lights at
//! infinity show in the background. Then it picks an emitter in proportion
//! to its power, samples a ray leaving it (see the emitters'
//! emission sampling) and follows it through the scene with BSDF sampling
//! in importance mode, connecting each non-delta vertex to the camera:
//! β · f · importance / d², with Veach's correction for shading normals
//! (adjoint BSDF, eq. 5.19). The camera's importance is its pixel count
//! times the density of its ray directions for uniform film positions, so
//! a splat is radiance per unit film area (in pixels); the image is the
//! sum of the splats over the number of paths.
//!
//! Splats are spread over the pixels by the film's filter, each pixel's
//! weights normalized by the filter's integral over the image
//! ([`crate::film::SplatImage`]), so that a pixel converges to what camera
//! paths give it. The paths are cut into fixed
//! chunks traced in parallel, each collecting its splats in a list; the
//! lists are added to the image in chunk order, so the image is the same
//! for any thread count.
//!
//! Emitters with `visible = false` are not rendered directly; there is no
//! "indirect visibility" for light paths, so `visible_indirect` has no
//! effect (a light seen in a mirror shows). Only cameras that can be
//! connected to a point (`perspective`, `thinlens`, `physical`: through
//! the lens as it samples itself) can be used; `orthographic` is a load
//! error. `ptracer` cannot be
//! nested in `aov` or `moment`.

use super::{max_depth_param, sample_chosen_light, Integrator};
use crate::bsdf::{BsdfContext, BsdfFlags, TransportMode};
use crate::film::SplatImage;
use crate::interaction::SurfaceInteraction;
use crate::light::{EmitterModel, SceneSphere};
use crate::math::{spawn_ray, Ray};
use crate::params::{ParamError, Params};
use crate::render::{RenderOutput, RenderSettings};
use crate::render::{RenderScene, RenderState};
use crate::sampler::SampleStream;
use crate::sampling::AliasTable;
use crate::{Rgb, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Light paths per chunk (the unit of parallel work and of progress).
const CHUNK_PATHS: u64 = 1 << 13;
/// Chunks traced in parallel before their splats are added to the image
/// (bounds the memory the splat lists take).
const CHUNKS_PER_BATCH: u64 = 32;

/// Particle tracer settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParticleTracer {
    /// Longest path in segments; negative means unlimited.
    pub max_depth: i32,
    /// Path length at which Russian roulette starts.
    pub rr_depth: u32,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
}

impl Default for ParticleTracer {
    fn default() -> Self {
        Self {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

impl ParticleTracer {
    /// Builds the integrator from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let t = Self {
            max_depth: max_depth_param(p)?,
            rr_depth: super::rr_depth_param(p)?,
            hide_emitters: p.boolean_or("hide_emitters", false)?,
        };
        // Mitsuba's unit of work; the result does not depend on it.
        p.integer("samples_per_pass")?;
        Ok(t)
    }

    /// Renders `scene` by tracing spp × pixels light paths (building the
    /// render's [`RenderState`] first).
    pub fn render(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        progress: &(dyn Fn(u64) + Sync),
        stop: &AtomicBool,
    ) -> RenderOutput {
        let state = RenderState::new(scene, self);
        let scene = &RenderScene::new(scene, &state);
        let film = &scene.film;
        let crop = film.crop_size;
        let pixels = u64::from(crop[0]) * u64::from(crop[1]);
        let total = pixels * u64::from(settings.spp);
        let mut image = SplatImage::new(film);
        let mut dropped = 0;
        let mut traced = 0;
        if let Some(lights) = PathStart::new(scene) {
            let chunks = total.div_ceil(CHUNK_PATHS);
            for batch in (0..chunks).step_by(CHUNKS_PER_BATCH as usize) {
                if stop.load(Ordering::Relaxed) {
                    break;
                }
                let end = (batch + CHUNKS_PER_BATCH).min(chunks);
                // One job per chunk (an indexed range, so that rayon can
                // split it down to single chunks for whichever thread is free).
                let results: Vec<(Vec<Splat>, u64)> = (0..(end - batch) as usize)
                    .into_par_iter()
                    .with_max_len(1)
                    .map(|i| {
                        let c = batch + i as u64;
                        let paths = c * CHUNK_PATHS..((c + 1) * CHUNK_PATHS).min(total);
                        let n = paths.end - paths.start;
                        let r = self.trace_chunk(scene, &lights, settings.seed, paths);
                        progress(n);
                        r
                    })
                    .collect();
                for (splats, bad) in results {
                    for s in splats {
                        image.splat(s.pos, s.rgb);
                    }
                    dropped += bad;
                }
                traced = (end * CHUNK_PATHS).min(total);
            }
        } else {
            // No light: every path is black, all traced at once.
            traced = total;
        }
        // Stopped early, the image is the estimate of the paths traced.
        let paths = if traced > 0 { traced } else { total };
        RenderOutput {
            image: image.to_framebuffer(if paths > 0 { 1.0 / paths as f64 } else { 0.0 }),
            layers: Vec::new(),
            dropped_samples: dropped,
            nonfinite: Default::default(),
            estimated_error: None,
            samples: traced,
        }
    }

    /// Traces the light paths `paths` (global indices) and returns their
    /// splats and the number of non-finite ones
    /// dropped.
    fn trace_chunk(
        &self,
        scene: &RenderScene,
        lights: &PathStart,
        seed: u32,
        paths: std::ops::Range<u64>,
    ) -> (Vec<Splat>, u64) {
        let crop = scene.film.crop_size;
        let offset = scene.film.crop_offset;
        let width = u64::from(crop[0]);
        let pixels = width * u64::from(crop[1]);
        let mut out = Splats {
            list: Vec::with_capacity((paths.end - paths.start) as usize * 2),
            dropped: 0,
            crop_offset: Vec2::new(offset[0] as f32, offset[1] as f32),
            crop_size: Vec2::new(crop[0] as f32, crop[1] as f32),
            reach: scene.film.filter.radius() + 1.0,
        };
        let timed = scene.samples_times();
        for i in paths {
            // Path i takes the sample stream of a pixel and sample index,
            // as a camera path would: a pure function of (i, seed).
            let q = i % pixels;
            let (x, y) = ((q % width) as u32, (q / width) as u32);
            let index = (i / pixels) as u32;
            let mut stream = scene
                .sampler
                .stream(x + offset[0], y + offset[1], index, seed);
            let scene = &if timed {
                scene.at_time(scene.shutter.time(stream.next_1d()))
            } else {
                *scene
            };
            if !self.hide_emitters {
                self.splat_visible_emitter(scene, &mut stream, &mut out);
            }
            self.trace_light_path(scene, lights, &mut stream, &mut out);
        }
        (out.list, out.dropped)
    }

    /// What the camera sees of the lights directly, for one sample.
    fn splat_visible_emitter(
        &self,
        scene: &RenderScene,
        sampler: &mut SampleStream,
        out: &mut Splats,
    ) {
        let u_pick = sampler.next_1d();
        let u = sampler.next_2d();
        let c = scene.camera.sample_lens(lens_sample(scene, sampler));
        let Some((light, pick_pdf)) = scene.pick_light(u_pick, c, Vec3::ZERO) else {
            return;
        };
        if !scene.emitter_options[light.emitter as usize].visible
            || scene.emitter(light.emitter).is_delta()
        {
            return;
        }
        let Some(ls) = sample_chosen_light(scene, light, c, u) else {
            return;
        };
        let Some((mut ray, film_p, importance)) = scene.camera.ray_towards(c, ls.wi) else {
            return;
        };
        if ls.dist.is_finite() {
            if !(ls.dist > ray.t_min && ls.dist < ray.t_max) {
                return;
            }
            ray.t_max = ls.dist * (1.0 - SHADOW_EPSILON);
        }
        let tr = scene.transmittance(&ray, self.crossings(1));
        if tr > 0.0 {
            out.push(
                film_p,
                ls.radiance * (tr * importance / (ls.pdf * pick_pdf)),
            );
        }
    }

    /// Follows one path from a light, connecting its vertices to the
    /// camera.
    fn trace_light_path(
        &self,
        scene: &RenderScene,
        lights: &PathStart,
        sampler: &mut SampleStream,
        out: &mut Splats,
    ) {
        let ctx = BsdfContext {
            mode: TransportMode::Importance,
            ..BsdfContext::default()
        };
        let u_pick = sampler.next_1d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let (emitter, _) = lights.table.sample(u_pick);
        let pick_pdf = lights.table.pmf(emitter);
        let Some(es) = scene.emitter(emitter as u32).sample_emission(
            &scene.emitter_context(),
            lights.sphere,
            u_pos,
            u_dir,
        ) else {
            return;
        };
        let mut beta = es.weight / pick_pdf;
        let mut ray = if es.n == Vec3::ZERO {
            es.ray
        } else {
            spawn_ray(es.ray.o, es.n, es.ray.d)
        };
        // Segments traced so far (the one from the light included).
        let mut depth: u32 = 1;
        loop {
            // Connecting a vertex to the camera adds one more segment.
            if self.max_depth >= 0 && depth + 1 > self.max_depth as u32 {
                break;
            }
            let Some(hit) = scene.closest(&ray) else {
                break;
            };
            let si = scene.interaction_at(&ray, &hit);
            let wo = si.to_local(si.wo);
            let bsdf = scene.bsdf_of(si.shape).at(&scene.materials, &si, wo);
            if scene.bsdf_flags_of(si.shape).intersects(BsdfFlags::SMOOTH) {
                let u_lens = lens_sample(scene, sampler);
                self.connect_to_camera(scene, &si, &bsdf, beta, depth, u_lens, out);
            }
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample(&ctx, u1, u2) else {
                break;
            };
            let wi = si.to_world(bs.wi);
            beta *= bs.weight * shading_normal_correction(&si, si.wo, wi);
            ray = si.spawn_ray(wi);
            depth += 1;
            if depth >= self.rr_depth {
                let q = beta.max_element().min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
            if beta.max_element() <= 0.0 || beta.is_nan() {
                break;
            }
        }
    }

    /// Splats the light that vertex `si` (reached with throughput `beta`
    /// after `depth` segments) scatters into the camera.
    #[allow(clippy::too_many_arguments)]
    fn connect_to_camera(
        &self,
        scene: &RenderScene,
        si: &SurfaceInteraction,
        bsdf: &crate::bsdf::Bsdf,
        beta: Rgb,
        depth: u32,
        u_lens: Vec2,
        out: &mut Splats,
    ) {
        let Some(sensor) = scene.camera.sample_towards(si.p, u_lens) else {
            return;
        };
        let ctx = BsdfContext {
            mode: TransportMode::Importance,
            ..BsdfContext::default()
        };
        let f = bsdf.eval(&ctx, si.to_local(sensor.wi));
        if f == Rgb::ZERO {
            return;
        }
        let correction = shading_normal_correction(si, si.wo, sensor.wi);
        let shadow = si.spawn_ray_to(sensor.origin);
        let tr = scene.transmittance(&shadow, self.crossings(depth + 1));
        if tr > 0.0 {
            let w = correction * tr * sensor.importance / (sensor.dist * sensor.dist);
            out.push(sensor.film_p, beta * f * w);
        }
    }

    /// Pass-through surfaces a connection may cross when the path has
    /// `segments` segments without them (each crossing counts as one, as
    /// in `path`).
    fn crossings(&self, segments: u32) -> u32 {
        match self.max_depth {
            d if d < 0 => u32::MAX,
            d => (d as u32).saturating_sub(segments),
        }
    }
}

/// The lens sample of a connection to the camera: drawn only for cameras
/// with a lens, so that pinhole images keep their sample streams.
fn lens_sample(scene: &RenderScene, sampler: &mut SampleStream) -> Vec2 {
    if scene.camera.needs_lens_sample() {
        sampler.next_2d()
    } else {
        Vec2::ZERO
    }
}

/// Shortens shadow rays towards a sampled light point so that they do not
/// hit the light itself.
const SHADOW_EPSILON: f32 = 1e-4;

/// Veach's correction for shading normals in importance transport
/// (1997, eq. 5.19): |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|), with `wo` towards
/// where the particle came from and `wi` where it goes.
fn shading_normal_correction(si: &SurfaceInteraction, wo: Vec3, wi: Vec3) -> f32 {
    let ns = si.sh_frame.n;
    let den = wo.dot(si.n).abs() * wi.dot(ns).abs();
    if den == 0.0 {
        return 0.0;
    }
    wo.dot(ns).abs() * wi.dot(si.n).abs() / den
}

/// How light paths start: emitters picked in proportion to their power,
/// and the scene's bounding sphere for lights at infinity.
struct PathStart {
    table: AliasTable,
    sphere: SceneSphere,
}

impl PathStart {
    /// `None` when no emitter has power.
    fn new(scene: &RenderScene) -> Option<Self> {
        let bounds = scene.bounds();
        let sphere = if bounds.is_empty() {
            SceneSphere {
                center: Vec3::ZERO,
                radius: 1.0,
            }
        } else {
            SceneSphere {
                center: bounds.center(),
                radius: (0.5 * bounds.extent().length()).max(1e-3),
            }
        };
        let ctx = scene.emitter_context();
        let powers: Vec<f32> = (scene.state().emitters().iter())
            .map(|e| {
                let p = e.power(&ctx, sphere.radius);
                if p.is_finite() {
                    p.max(0.0)
                } else {
                    0.0
                }
            })
            .collect();
        Some(Self {
            table: AliasTable::new(&powers)?,
            sphere,
        })
    }
}

/// A value to add to the image at a film position (full-image pixels).
#[derive(Clone, Copy, Debug)]
struct Splat {
    pos: Vec2,
    rgb: [f32; 3],
}

/// A chunk's splats.
struct Splats {
    list: Vec<Splat>,
    dropped: u64,
    crop_offset: Vec2,
    crop_size: Vec2,
    /// The filter's radius: how far outside the crop a splat still counts.
    reach: f32,
}

impl Splats {
    /// Adds `value` at full-image film position `film_p`, if it is finite
    /// and the filter lets it reach the crop window.
    fn push(&mut self, film_p: Vec2, value: Rgb) {
        if !value.is_finite() {
            self.dropped += 1;
            return;
        }
        if value == Rgb::ZERO {
            return;
        }
        // Splats beyond the filter's reach of the crop window are lost.
        let pos = film_p - self.crop_offset;
        let r = self.reach;
        if pos.x < -r || pos.y < -r || pos.x > self.crop_size.x + r || pos.y > self.crop_size.y + r
        {
            return;
        }
        self.list.push(Splat {
            pos: film_p,
            rgb: value.to_array(),
        });
    }
}

impl Integrator for ParticleTracer {
    fn li(&self, _: &RenderScene, _: &Ray, _: &mut SampleStream) -> Rgb {
        // Never called: `particle_tracer` routes renders to `render`, and
        // nesting integrators refuse a particle tracer.
        Rgb::ZERO
    }

    fn particle_tracer(&self) -> Option<&ParticleTracer> {
        Some(self)
    }
}
