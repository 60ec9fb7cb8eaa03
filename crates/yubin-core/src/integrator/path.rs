//! `path`: unidirectional path tracing with next-event estimation at every
//! bounce, multiple importance sampling (power heuristic) between light
//! and BSDF sampling, and Russian roulette (Veach 1997, ch. 9;
//! pbrt-v4 §13.4).
//!
//! | parameter       | type    | default | meaning                                                        |
//! |-----------------|---------|---------|----------------------------------------------------------------|
//! | `max_depth`     | integer | -1      | longest path in segments (−1: unlimited); 1 = visible emitters only, 2 = direct light |
//! | `rr_depth`      | integer | 5       | Russian roulette starts once a path has this many segments     |
//! | `hide_emitters` | boolean | false   | emitters seen directly by the camera render black              |
//! | `light_sampler` | string  | bvh     | how light sampling picks an emitter: `uniform` (Mitsuba's rule, by `sampling_weight`), `power`, `bvh` (yubin) |
//! | `mis_compensation` | boolean | true | leave to BSDF sampling the light it finds well: `constant` emitters are not light-sampled, `envmap`s and `preetham`'s sky sample their excess over their mean (yubin; false: Mitsuba's rule) |
//!
//! ```xml
//! <integrator type="path"><integer name="max_depth" value="8"/></integrator>
//! ```
//!
//! The roulette survival probability is min(max(β)·η², 0.95), with β the
//! throughput and η the accumulated relative index of refraction.
//!
//! **MIS compensation.** Every light sample is followed by a BSDF sample
//! from the same vertex, and emitters hit by BSDF samples are weighed
//! against light sampling by MIS, so light sampling need not cover what
//! BSDF sampling finds well (Karlík, Šik, Vévoda, Skřivan and Křivánek
//! 2019, "MIS Compensation: Optimizing Sampling Techniques in Multiple
//! Importance Sampling", ACM TOG 38(6); pbrt-v4's `allowIncompletePDF`):
//! with `mis_compensation` (the default) a `constant` emitter is never
//! chosen for light sampling — cosine-weighted and glossy BSDF samples
//! find a uniform sky better than uniform directions on the sphere, half of
//! which point into the surface — and its share of the light samples goes
//! to the other emitters; an `envmap` (and `preetham`'s sky) samples the
//! excess of its radiance over its mean, where the sun and bright windows
//! are. Emitters hidden from indirect rays (`visible_indirect` false) keep
//! full light sampling, as BSDF samples cannot find them. The images are the same in the mean;
//! their noise is lower wherever a sky lights the scene (BENCHMARKS.md).
//! The exception is a room lit through a small opening by a part of the
//! sky that is dimmer than the sky's mean: light sampling then no longer
//! aims at it and BSDF samples seldom find the opening; set
//! `mis_compensation` to false for such a scene.

use super::max_depth_param;
use super::wide::{self, DiffuseBatch, DiffuseShading, DiffuseSides, DiffuseVertex};
use super::{
    add_environment_radiance, light_sample_unshadowed_by, sample_chosen_light,
    sample_light_unshadowed_by, shadow_ray_towards, surface_emission, Integrator, LightDraw,
    PickedLightSample, RayOrigin, UnshadowedSample,
};
use crate::accel::PACKET_RAYS;
use crate::bsdf::{BsdfContext, BsdfFlags, BsdfSample};
use crate::interaction::SurfaceInteraction;
use crate::light::{EmitterSample, LightChoice, LightSelection};
use crate::math::spawn_ray;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::scene::{HitRecord, LightView};
use crate::Rgb;
use glam::Vec3;

/// Path tracer settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathIntegrator {
    /// Longest path in segments; negative means unlimited.
    pub max_depth: i32,
    /// Path length at which Russian roulette starts.
    pub rr_depth: u32,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
    /// How emitters are chosen for light sampling (`None`: the default).
    pub light_selection: Option<LightSelection>,
    /// Leave to BSDF sampling the light it finds well (module docs).
    pub mis_compensation: bool,
}

impl PathIntegrator {
    /// Builds the integrator from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            max_depth: max_depth_param(p)?,
            rr_depth: super::rr_depth_param(p)?,
            hide_emitters: p.boolean_or("hide_emitters", false)?,
            light_selection: LightSelection::from_params(p)?,
            mis_compensation: p.boolean_or("mis_compensation", true)?,
        })
    }
}

impl Default for PathIntegrator {
    fn default() -> Self {
        Self {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
            light_selection: None,
            mis_compensation: true,
        }
    }
}

impl Integrator for PathIntegrator {
    fn light_selection(&self) -> Option<LightSelection> {
        self.light_selection
    }

    fn mis_compensation(&self) -> bool {
        self.mis_compensation
    }

    fn li(&self, scene: &RenderScene, camera_ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        let mut path = Path::new(camera_ray);
        loop {
            let hit = if scene.has_portals() {
                path.trace_through_portals(scene)
            } else {
                scene.closest(&path.ray)
            };
            if !self.bounce(scene, &mut path, hit, sampler) {
                break;
            }
        }
        path.l
    }

    /// Eight paths at a time, their rays traced together
    /// ([`crate::Scene::closest_packet`]): a path that ends hands its lane to the
    /// next camera ray, so the packet stays full until the rays run out.
    /// Each path is the same, bit for bit, as [`Integrator::li`] traces
    /// it alone.
    fn sample_packet(
        &self,
        scene: &RenderScene,
        rays: &[Option<Ray>],
        samplers: &mut [SampleStream],
        out: &mut [f32],
    ) {
        if scene.has_portals() {
            // Paths through portals are traced one by one.
            for ((ray, sampler), out) in rays
                .iter()
                .zip(samplers)
                .zip(out.chunks_mut(self.channel_count()))
            {
                out.fill(0.0);
                if let Some(ray) = ray {
                    out.copy_from_slice(&self.li(scene, ray, sampler).to_array());
                }
            }
            return;
        }
        let mut lanes = Lanes {
            paths: std::array::from_fn(|_| Path::new(&Ray::new(Vec3::ZERO, Vec3::Z))),
            sample: [0; PACKET_RAYS],
            alive: 0,
            next: 0,
        };
        for lane in 0..PACKET_RAYS {
            lanes.refill(lane, rays, out);
        }
        let mut batch = DiffuseBatch::default();
        // Per batch entry: its lane, point, geometric normal, reflectance.
        let mut queued = [(0usize, Vec3::ZERO, Vec3::ZERO, Rgb::ZERO); wide::LANES];
        let mut shading = [DiffuseShading::default(); wide::LANES];
        let mut hits = [None; PACKET_RAYS];
        let mut shadows = Shadows::new();
        while lanes.alive != 0 {
            let next_rays = lanes.paths.each_ref().map(|p| p.ray);
            scene.closest_packet(&next_rays, lanes.alive, &mut hits);
            batch.clear();
            // The lanes whose path ends at this bounce, handed on once
            // their light samples' shadow rays are traced.
            let mut ending = 0u32;
            for (lane, &hit) in hits.iter().enumerate() {
                if lanes.alive >> lane & 1 == 0 {
                    continue;
                }
                let sample = lanes.sample[lane];
                let path = &mut lanes.paths[lane];
                let sampler = &mut samplers[sample];
                let Some(hit) = hit else {
                    self.escape(scene, path);
                    ending |= 1 << lane;
                    continue;
                };
                let si = scene.interaction_at(&path.ray, &hit);
                let shadows = (&mut shadows, lane);
                let goes_on = self.land(scene, path, &si)
                    && match scene.diffuse_sides_of(si.shape) {
                        Some(sides) => {
                            let i = batch.len();
                            let queued_now = self.queue_diffuse(
                                scene, path, &si, sides, sampler, &mut batch, shadows,
                            );
                            if let Some(reflectance) = queued_now {
                                queued[i] = (lane, si.p, si.n, reflectance);
                            }
                            queued_now.is_some()
                        }
                        None => self.scatter(scene, path, &si, sampler, Some(shadows)),
                    };
                if !goes_on {
                    ending |= 1 << lane;
                }
            }
            if batch.len() != 0 {
                batch.shade(&mut shading);
                for (&(lane, p, n, reflectance), shading) in
                    queued.iter().zip(&shading).take(batch.len())
                {
                    let sample = lanes.sample[lane];
                    let path = &mut lanes.paths[lane];
                    if !self.finish_diffuse(
                        scene,
                        path,
                        (p, n),
                        reflectance,
                        shading,
                        &mut samplers[sample],
                        (&mut shadows, lane),
                    ) {
                        ending |= 1 << lane;
                    }
                }
            }
            shadows.trace(scene, &mut lanes.paths);
            for lane in (0..PACKET_RAYS).filter(|l| ending >> l & 1 != 0) {
                lanes.finish(lane, rays, out);
            }
        }
    }
}

/// Next-event estimation at `si` in world `world` of a scene with
/// portals, shadow ray traced: the vertex looks directly at its world's
/// emitters or through one of its portal sides at the far world's (see
/// `scene/worlds.rs`); zero when the chosen emitter is in another world
/// than the one looked into. The view is chosen by the light choice's
/// number, stretched, so the sample draws the numbers it draws without
/// portals.
fn light_sample_through_portals(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    world: u32,
    sampler: &mut SampleStream,
    eval: impl FnOnce(Vec3, bool) -> (Rgb, f32),
) -> Rgb {
    let draw = LightDraw::draw(sampler);
    let views = scene.light_views(world);
    let count = views.len();
    let stretched = draw.u_pick * count as f32;
    let view = (stretched as usize).min(count.saturating_sub(1));
    let u_pick = (stretched - view as f32).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
    let view_pdf = 1.0 / count as f32;
    let side = match views.get(view) {
        None => return Rgb::ZERO,
        Some(LightView::Own) => {
            return light_sample_in_world(scene, si, world, u_pick, draw.u, view_pdf, eval)
                .filter(|l| !scene.occluded_in(&l.shadow, world))
                .map_or(Rgb::ZERO, |l| l.through(1.0));
        }
        Some(&LightView::Through(side)) => side,
    };
    let Some(portal) = scene.portal_of(side) else {
        return Rgb::ZERO;
    };
    let (map, unmap) = (portal.map, portal.map.inverse());
    // The vertex as the far world sees it through the portal.
    let (p, n) = (map.point(si.p), map.normal(si.n).normalize_or_zero());
    let Some((light, pick_pdf)) = scene.pick_light_in(portal.to_world, u_pick, p, n) else {
        return Rgb::ZERO;
    };
    let Some(ls) = sample_chosen_light(scene, light, p, draw.u) else {
        return Rgb::ZERO;
    };
    let target = ls.dist.is_finite().then(|| p + ls.wi * ls.dist);
    let picked = PickedLightSample {
        ls: EmitterSample {
            wi: unmap.vector(ls.wi).normalize(),
            dist: f32::INFINITY,
            ..ls
        },
        pick_pdf: pick_pdf * view_pdf,
        emitter: light.emitter,
    };
    let Some(l) = light_sample_unshadowed_by(scene, si, &picked, 1.0, eval) else {
        return Rgb::ZERO;
    };
    if scene.visible_through(&l.shadow, world, side, target) {
        l.through(1.0)
    } else {
        Rgb::ZERO
    }
}

/// A light sample at `si` of world `world`'s own emitters, chosen by
/// `u_pick` (none when the chosen emitter is in another world), its
/// density scaled by `view_pdf`.
fn light_sample_in_world(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    world: u32,
    u_pick: f32,
    u: glam::Vec2,
    view_pdf: f32,
    eval: impl FnOnce(Vec3, bool) -> (Rgb, f32),
) -> Option<UnshadowedSample> {
    let (light, pick_pdf) = scene.pick_light_in(world, u_pick, si.p, si.n)?;
    let ls = sample_chosen_light(scene, light, si.p, u)?;
    let picked = PickedLightSample {
        ls,
        pick_pdf: pick_pdf * view_pdf,
        emitter: light.emitter,
    };
    light_sample_unshadowed_by(scene, si, &picked, 1.0, eval)
}

/// Adds the light sample `l` to `path`, its shadow ray traced now through
/// at most `crossings` pass-through surfaces (out of line: the queued
/// samples are the common case). By value, so that the sample is copied
/// to memory on this path alone: by reference, the caller kept it in
/// memory on the queued path too, stored in pieces and read back whole
/// for the queue, which the CPU cannot forward.
#[inline(never)]
fn add_shadowed(scene: &RenderScene, path: &mut Path, l: UnshadowedSample, crossings: u32) {
    path.l += path.beta * l.shadowed(scene, crossings);
}

/// The light samples of a packet's bounce whose shadow rays are still to
/// be traced, at most one per lane: traced together
/// ([`crate::Scene::occluded_packet`]) before any path goes on, each adds its
/// contribution to its path unless something blocks it. Only plain
/// any-hit queries wait here (see [`Shadows::takes`]).
struct Shadows {
    rays: [Ray; PACKET_RAYS],
    /// Per entry: its lane and what it adds (throughput included).
    lanes: [usize; PACKET_RAYS],
    adds: [Rgb; PACKET_RAYS],
    len: usize,
}

impl Shadows {
    fn new() -> Self {
        Self {
            rays: [Ray::new(Vec3::ZERO, Vec3::Z); PACKET_RAYS],
            lanes: [0; PACKET_RAYS],
            adds: [Rgb::ZERO; PACKET_RAYS],
            len: 0,
        }
    }

    /// Whether a shadow ray that may cross `crossings` pass-through
    /// surfaces is a plain any-hit query, which may wait here.
    #[inline]
    fn takes(scene: &RenderScene, crossings: u32) -> bool {
        !scene.has_pass_through() || crossings == 0
    }

    /// Queues `add` for `lane`'s path, due unless something blocks `ray`.
    #[inline]
    fn push(&mut self, lane: usize, add: Rgb, ray: Ray) {
        let i = self.len;
        self.rays[i] = ray;
        self.lanes[i] = lane;
        self.adds[i] = add;
        self.len += 1;
    }

    /// Traces the waiting shadow rays and adds what gets through to the
    /// paths. The lanes of `rays` past `len` keep stale rays, unread.
    fn trace(&mut self, scene: &RenderScene, paths: &mut [Path; PACKET_RAYS]) {
        let n = self.len;
        self.len = 0;
        let blocked = match n {
            0 => return,
            1 => u32::from(scene.occluded(&self.rays[0])),
            _ => scene.occluded_packet(&self.rays, (1 << n) - 1),
        };
        for i in (0..n).filter(|i| blocked >> i & 1 == 0) {
            paths[self.lanes[i]].l += self.adds[i];
        }
    }
}

/// The paths of a packet's lanes (see [`PathIntegrator::sample_packet`]).
struct Lanes {
    paths: [Path; PACKET_RAYS],
    /// Per lane, the camera sample its path is.
    sample: [usize; PACKET_RAYS],
    /// The lanes that hold a path.
    alive: u32,
    /// The next camera sample to start.
    next: usize,
}

impl Lanes {
    /// Writes the radiance of the path in `lane`, which has ended, and
    /// starts the next one there.
    fn finish(&mut self, lane: usize, rays: &[Option<Ray>], out: &mut [f32]) {
        let sample = self.sample[lane];
        out[3 * sample..3 * sample + 3].copy_from_slice(&self.paths[lane].l.to_array());
        self.refill(lane, rays, out);
    }

    /// Starts the next camera ray's path in `lane`, or leaves the lane
    /// empty when none is left; a missing ray (the lens stopped it) is
    /// black.
    fn refill(&mut self, lane: usize, rays: &[Option<Ray>], out: &mut [f32]) {
        self.alive &= !(1 << lane);
        while let Some(ray) = rays.get(self.next) {
            let sample = self.next;
            self.next += 1;
            match ray {
                Some(ray) => {
                    self.paths[lane] = Path::new(ray);
                    self.sample[lane] = sample;
                    self.alive |= 1 << lane;
                    return;
                }
                None => out[3 * sample..3 * sample + 3].fill(0.0),
            }
        }
    }
}

/// A path between bounces.
struct Path {
    /// Radiance gathered so far.
    l: Rgb,
    /// Throughput.
    beta: Rgb,
    /// Squared relative index of refraction accumulated (for roulette).
    eta2: f32,
    /// The ray to trace next.
    ray: Ray,
    /// The vertex that BSDF-sampled `ray`, with the density (None for
    /// camera rays and delta lobes: no MIS, the light could not sample
    /// them). Crossing a pass-through surface keeps it: that vertex's
    /// light samples reach the same emitters through the same surfaces.
    origin: RayOrigin,
    /// Number of segments traced so far minus one (0 at the first hit).
    depth: u32,
    /// The world the path is in (portals; 0 without them).
    world: u32,
}

impl Path {
    fn new(camera_ray: &Ray) -> Self {
        Self {
            l: Rgb::ZERO,
            beta: Rgb::ONE,
            eta2: 1.0,
            ray: *camera_ray,
            origin: RayOrigin::camera(camera_ray.o),
            depth: 0,
            world: 0,
        }
    }

    /// The closest hit of the path's ray, through portals: the ray becomes
    /// its last segment, and its origin what MIS weighs an emitter it
    /// finds against (see `scene/worlds.rs`): the vertex as seen through
    /// the one portal crossed, or no MIS after two crossings (or one that
    /// light sampling does not look through).
    #[inline]
    fn trace_through_portals(&mut self, scene: &RenderScene) -> Option<HitRecord> {
        let from = self.world;
        let traced = scene.trace(&mut self.ray, &mut self.world);
        let views = scene.light_views(from);
        let seen = match traced.crossings {
            0 => views.contains(&LightView::Own),
            1 => views.contains(&LightView::Through(traced.first_side)),
            _ => false,
        };
        if !seen {
            self.origin.bsdf_pdf = None;
        } else if traced.crossings == 1 {
            if let Some(portal) = scene.portal_of(traced.first_side) {
                self.origin.p = portal.map.point(self.origin.p);
                self.origin.n = portal.map.normal(self.origin.n).normalize_or_zero();
            }
        }
        // Light sampling looks this way with probability 1/k: the light
        // density MIS weighs against is that much smaller. The power
        // heuristic depends on the ratio of the densities alone, so the
        // BSDF density is scaled up instead.
        let views = views.len() as f32;
        self.origin.bsdf_pdf = self.origin.bsdf_pdf.map(|pdf| pdf * views);
        self.origin.world = self.world;
        traced.hit
    }
}

impl PathIntegrator {
    /// Continues `path` where its ray meets the scene (`hit`, the ray's
    /// closest hit): emission, next-event estimation, the BSDF sample of
    /// the next ray and roulette. False when the path ends.
    fn bounce(
        &self,
        scene: &RenderScene,
        path: &mut Path,
        hit: Option<HitRecord>,
        sampler: &mut SampleStream,
    ) -> bool {
        let Some(hit) = hit else {
            self.escape(scene, path);
            return false;
        };
        let si = scene.interaction_at(&path.ray, &hit);
        self.land(scene, path, &si) && self.scatter(scene, path, &si, sampler, None)
    }

    /// The emission from infinity that the path's ray finds when it
    /// escapes the scene, which ends the path.
    fn escape(&self, scene: &RenderScene, path: &mut Path) {
        if !(path.depth == 0 && self.hide_emitters) {
            let d = path.ray.d.normalize();
            add_environment_radiance(scene, &path.origin, d, path.beta, &mut path.l);
        }
    }

    /// The emission of the surface `si` that the path's ray meets; false
    /// when the path may not go on from it (its longest length).
    #[inline]
    fn land(&self, scene: &RenderScene, path: &mut Path, si: &SurfaceInteraction) -> bool {
        let depth = path.depth;
        if !(depth == 0 && self.hide_emitters) {
            path.l += path.beta * surface_emission(scene, si, &path.origin);
        }
        !(self.max_depth >= 0 && depth + 1 >= self.max_depth as u32)
    }

    /// How many pass-through surfaces a light sample's shadow ray from a
    /// vertex at `depth` may cross: as many as the BSDF sample's path
    /// could (each crossing counts as a bounce, as in Mitsuba), leaving
    /// room for the segment that reaches the light.
    #[inline]
    fn crossings(&self, depth: u32) -> u32 {
        match self.max_depth {
            d if d < 0 => u32::MAX,
            d => (d as u32).saturating_sub(depth + 2),
        }
    }

    /// Next-event estimation and the BSDF sample at `si`, then
    /// [`PathIntegrator::follow`]; the light sample's shadow ray waits in
    /// `shadows` (with the path's lane) where it may. False when the path
    /// ends.
    fn scatter(
        &self,
        scene: &RenderScene,
        path: &mut Path,
        si: &SurfaceInteraction,
        sampler: &mut SampleStream,
        shadows: Option<(&mut Shadows, usize)>,
    ) -> bool {
        let wo = si.to_local(si.wo);
        // The BSDF at the vertex, made once for both samples.
        let bsdf = scene.bsdf_of(si.shape).at(&scene.materials, si, wo);
        let ctx = BsdfContext::default();
        if scene.bsdf_flags_of(si.shape).intersects(BsdfFlags::SMOOTH) {
            let eval = |wi, mis| bsdf.eval_pdf_if(&ctx, wi, mis);
            if scene.has_portals() {
                path.l +=
                    path.beta * light_sample_through_portals(scene, si, path.world, sampler, eval);
            } else if let Some(l) = sample_light_unshadowed_by(scene, si, sampler, 1.0, eval) {
                self.add_light_sample(scene, path, &l, shadows);
            }
        }
        let u1 = sampler.next_1d();
        let u2 = sampler.next_2d();
        let Some(bs) = bsdf.sample(&ctx, u1, u2) else {
            return false;
        };
        let wi = si.to_world(bs.wi);
        self.follow(path, si.p, si.n, &bs, wi, sampler)
    }

    /// Adds the light sample `l` to `path`: its shadow ray traced now, or
    /// queued in `shadows` (with the path's lane) to be traced with the
    /// bounce's others where it is a plain any-hit query.
    #[inline(always)]
    fn add_light_sample(
        &self,
        scene: &RenderScene,
        path: &mut Path,
        l: &UnshadowedSample,
        shadows: Option<(&mut Shadows, usize)>,
    ) {
        let crossings = self.crossings(path.depth);
        match shadows {
            Some((queue, lane)) if Shadows::takes(scene, crossings) => {
                queue.push(lane, path.beta * l.through(1.0), l.shadow);
            }
            _ => add_shadowed(scene, path, *l, crossings),
        }
    }

    /// The path goes on from the surface point `p` (geometric normal `n`)
    /// along the BSDF sample `bs`, whose direction is `wi` in world
    /// space; Russian roulette. False when the path ends.
    #[inline]
    fn follow(
        &self,
        path: &mut Path,
        p: Vec3,
        n: Vec3,
        bs: &BsdfSample,
        wi: Vec3,
        sampler: &mut SampleStream,
    ) -> bool {
        path.beta *= bs.weight;
        path.eta2 *= bs.eta * bs.eta;
        if bs.sampled != BsdfFlags::NULL {
            let pdf = (!bs.sampled.intersects(BsdfFlags::DELTA)).then_some(bs.pdf);
            path.origin = RayOrigin::surface_at(p, n, pdf);
        }
        path.ray = spawn_ray(p, n, wi);
        path.depth += 1;
        if path.depth >= self.rr_depth {
            let q = (path.beta.max_element() * path.eta2).min(0.95);
            if sampler.next_1d() >= q {
                return false;
            }
            path.beta /= q;
        }
        if path.beta.max_element() <= 0.0 {
            return false;
        }
        true
    }

    /// [`PathIntegrator::scatter`] for a vertex whose BSDF is `sides`:
    /// draws its numbers, and queues in `batch` what the wide shading
    /// computes (the BSDF sample, and the light sample when the chosen
    /// light is a rectangle's constant area light; other light samples
    /// are taken here, their shadow rays queued in `shadows`). The
    /// reflectance it queued, or `None` when the path ends here.
    #[inline]
    fn queue_diffuse(
        &self,
        scene: &RenderScene,
        path: &mut Path,
        si: &SurfaceInteraction,
        sides: DiffuseSides,
        sampler: &mut SampleStream,
        batch: &mut DiffuseBatch,
        shadows: (&mut Shadows, usize),
    ) -> Option<Rgb> {
        let wo = si.to_local(si.wo);
        let draw = LightDraw::draw(sampler);
        // `diffuse` reads only the pair; the single number is drawn all
        // the same, so the stream's dimensions are those `scatter` draws.
        let _u1 = sampler.next_1d();
        let u_bsdf = sampler.next_2d();
        // Seen from where it reflects nothing, the light sample and the
        // BSDF sample both vanish.
        let (reflectance, flip) = sides.facing(&scene.materials, si, wo)?;
        let mut light = None;
        if let Some((choice, pick_pdf)) = scene.pick_light(draw.u_pick, si.p, si.n) {
            let rectangle = scene.rectangle_light(choice.emitter);
            if let Some(r) = rectangle.filter(|_| choice.prim == LightChoice::WHOLE) {
                light = Some((r, draw.u, pick_pdf));
            } else if let Some(ls) = sample_chosen_light(scene, choice, si.p, draw.u) {
                let picked = PickedLightSample {
                    ls,
                    pick_pdf,
                    emitter: choice.emitter,
                };
                // The BSDF as `diffuse` (mirrored by `twosided`) evaluates
                // it, from the reflectance read above.
                let eval = |wi: Vec3, _| DiffuseSides::eval_pdf(reflectance, flip, wi);
                if let Some(l) = light_sample_unshadowed_by(scene, si, &picked, 1.0, eval) {
                    self.add_light_sample(scene, path, &l, Some(shadows));
                }
            }
        }
        batch.push(&DiffuseVertex {
            p: si.p,
            frame: si.sh_frame,
            reflectance,
            flip,
            u_bsdf,
            light,
        });
        Some(reflectance)
    }

    /// The rest of a queued vertex's bounce, from its wide shading: the
    /// light sample's contribution (its shadow ray queued in `shadows`
    /// where it may wait), then [`PathIntegrator::follow`] along the BSDF
    /// sample. `p` and `n` are the vertex's point and geometric normal,
    /// `reflectance` its BSDF sample's weight. False when the path ends.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn finish_diffuse(
        &self,
        scene: &RenderScene,
        path: &mut Path,
        (p, n): (Vec3, Vec3),
        reflectance: Rgb,
        shading: &DiffuseShading,
        sampler: &mut SampleStream,
        shadows: (&mut Shadows, usize),
    ) -> bool {
        if let Some(ls) = &shading.light {
            let l = UnshadowedSample {
                f_le: ls.f_le,
                w: ls.w,
                light_pdf: ls.pdf,
                shadow: shadow_ray_towards(p, n, ls.wi, ls.dist),
            };
            self.add_light_sample(scene, path, &l, Some(shadows));
        }
        let Some((wi, pdf)) = shading.bsdf else {
            return false;
        };
        let bs = BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
            weight: reflectance,
        };
        self.follow(path, p, n, &bs, wi, sampler)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Dielectric, Diffuse, Material, TwoSided};
    use crate::camera::{Camera, FovAxis, Perspective};
    use crate::math::Transform;
    use crate::render::RenderState;
    use crate::shape::{Rectangle, Shape, Sphere};
    use crate::{Scene, SceneBuilder};
    use glam::Affine3A;

    /// A lit box of rectangles (one checkered) with a diffuse and a glass
    /// sphere, and a two-sided panel.
    fn room() -> Scene {
        let mut b = SceneBuilder::new();
        let white = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::splat(0.7))));
        let glass = b.add_bsdf(Material::Dielectric(Dielectric::new(1.5)));
        // A checkered wall: a textured reflectance, evaluated per vertex.
        let checks = b.add_texture(crate::texture::Texture::Checkerboard(
            crate::texture::Checkerboard {
                color0: Rgb::new(0.8, 0.2, 0.2).into(),
                color1: Rgb::new(0.1, 0.6, 0.9).into(),
                to_uv: glam::Affine2::from_scale(glam::Vec2::splat(5.0)),
                float_swapped: false,
            },
        ));
        let checkered = b.add_bsdf(Material::Diffuse(Diffuse {
            reflectance: crate::texture::Tex::Texture(checks),
        }));
        let wall =
            |m: Affine3A| Shape::Rectangle(Rectangle::new(Transform::new(m).unwrap(), false));
        for (m, bsdf) in [
            (
                Affine3A::from_translation(Vec3::new(0.0, 0.0, -1.0)),
                checkered,
            ),
            (
                Affine3A::from_translation(Vec3::new(0.0, -1.0, 0.0))
                    * Affine3A::from_rotation_x(-1.57),
                white,
            ),
            (
                Affine3A::from_translation(Vec3::new(1.0, 0.0, 0.0))
                    * Affine3A::from_rotation_y(-1.57),
                white,
            ),
        ] {
            b.add_shape(wall(m), Some(bsdf), None).unwrap();
        }
        let light = Affine3A::from_translation(Vec3::new(0.0, 0.99, 0.0))
            * Affine3A::from_rotation_x(1.57)
            * Affine3A::from_scale(Vec3::splat(0.3));
        b.add_shape(wall(light), None, Some(Rgb::splat(10.0).into()))
            .unwrap();
        // Lights other than rectangles: their samples at diffuse vertices
        // are weighed apart from the wide shading (a delta light, and a
        // small glowing sphere, which MIS weighs).
        b.add_emitter(crate::light::Emitter::Point(crate::light::PointLight {
            position: Vec3::new(0.5, 0.6, 0.4),
            intensity: Rgb::new(0.6, 0.5, 0.4),
        }));
        let glow = Shape::Sphere(Sphere::new(Vec3::new(-0.6, 0.7, -0.5), 0.08, false));
        b.add_shape(glow, None, Some(Rgb::new(4.0, 6.0, 8.0).into()))
            .unwrap();
        // A panel seen from both sides, each with its own colour.
        let front = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::new(0.2, 0.6, 0.3))));
        let back = b.add_bsdf(Material::Diffuse(Diffuse::new(Rgb::new(0.8, 0.3, 0.1))));
        let panel = b.add_bsdf(Material::TwoSided(TwoSided { front, back }));
        let panel_at = Affine3A::from_translation(Vec3::new(-0.5, 0.1, 0.0))
            * Affine3A::from_rotation_y(2.6)
            * Affine3A::from_scale(Vec3::splat(0.3));
        b.add_shape(wall(panel_at), Some(panel), None).unwrap();
        for (c, bsdf) in [
            (Vec3::new(-0.4, -0.6, -0.3), white),
            (Vec3::new(0.4, -0.6, 0.2), glass),
        ] {
            let sphere = Shape::Sphere(Sphere::new(c, 0.35, false));
            b.add_shape(sphere, Some(bsdf), None).unwrap();
        }
        let to_world =
            Affine3A::look_at_lh(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y).inverse();
        b.camera(Camera::Perspective(Perspective::new(
            to_world,
            40.0,
            FovAxis::X,
            8,
            8,
            0.01,
            100.0,
        )));
        b.build().unwrap()
    }

    /// Paths traced in packets (lanes refilled as paths end, some camera
    /// rays missing; diffuse vertices shaded eight at a time, textured and
    /// not, from both sides of a two-sided panel, with the rectangle light
    /// sampled by area and by solid angle, and a point light and a glowing
    /// sphere sampled apart) give each sample the value `li` gives it
    /// alone.
    #[test]
    fn packets_of_paths_equal_single_paths() {
        let scene = room();
        let integrator = PathIntegrator::default();
        let state = RenderState::new(&scene, &integrator);
        let scene = RenderScene::new(&scene, &state);
        let mut rays = Vec::new();
        let mut streams = Vec::new();
        for index in 0..300u32 {
            let (x, y) = (index % 8, index / 8 % 8);
            let mut stream = scene.sampler.stream(x, y, index, 3);
            let film_p = glam::Vec2::new(x as f32, y as f32) + stream.next_2d();
            // Every seventh ray stopped, as a lens would stop it.
            rays.push(
                scene
                    .camera
                    .generate_ray(film_p, glam::Vec2::ZERO)
                    .filter(|_| index % 7 != 3),
            );
            streams.push(stream);
        }
        let mut single = vec![f32::NAN; 3 * rays.len()];
        for ((ray, stream), out) in rays.iter().zip(streams.clone()).zip(single.chunks_mut(3)) {
            out.fill(0.0);
            if let Some(ray) = ray {
                integrator.sample(&scene, ray, &mut stream.clone(), out);
            }
        }
        let mut packed = vec![f32::NAN; 3 * rays.len()];
        integrator.sample_packet(&scene, &rays, &mut streams, &mut packed);
        assert_eq!(
            single.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            packed.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert!(
            single.iter().filter(|&&v| v > 0.0).count() > 100,
            "{single:?}"
        );
    }
}
