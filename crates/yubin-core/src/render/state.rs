//! What a render builds from the scene for its integrator, once, when it
//! starts ([`RenderState`]), and the view integrators get of the two
//! together ([`RenderScene`]).
//!
//! A [`Scene`] is what the scene describes; how its lights are chosen and
//! sampled depends on the integrator too (its `light_sampler` and
//! `mis_compensation` parameters), and the tables that only an
//! integrator reads are the integrator's business. So none of it lives
//! in the scene: the render loops ([`super::render`],
//! [`super::Progressive`], the particle tracer's own loop) build a
//! `RenderState` once per render, and integrators see the scene through
//! a `RenderScene`, which is the scene (it dereferences to it, so
//! geometry and material queries read as before) plus light selection
//! and the emitters as the render samples them.

use crate::integrator::wide::{DiffuseSides, RectangleLight, WideTables};
use crate::integrator::Integrator;
use crate::interaction::SurfaceInteraction;
use crate::light::{
    selection::left_to_bsdf_sampling, Emitter, EmitterContext, LightChoice, LightSampler,
    LightSelection,
};
use crate::sampling::Distribution2D;
use crate::scene::LightView;
use crate::Scene;

/// How a render chooses and samples lights: what its integrator asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightOptions {
    /// How next-event estimation chooses emitters.
    pub selection: LightSelection,
    /// Whether light sampling may leave to BSDF sampling the light it
    /// finds well ([`Integrator::mis_compensation`]).
    pub mis_compensation: bool,
}

impl LightOptions {
    /// What `integrator` asks for: its [`Integrator::light_selection`]
    /// (the default one when it says nothing) and its
    /// [`Integrator::mis_compensation`].
    pub fn of(integrator: &dyn Integrator) -> Self {
        Self {
            selection: integrator.light_selection().unwrap_or_default(),
            mis_compensation: integrator.mis_compensation(),
        }
    }
}

/// What a render builds from a scene for its integrator, once when it
/// starts: the emitters as it samples them (the scene's, pointed at the
/// render's sampling distributions, which depend on MIS compensation),
/// those distributions, the light sampler, and the tables of the wide
/// path shading.
#[derive(Clone, Debug)]
pub struct RenderState {
    /// The scene's emitters, each `envmap` and `preetham` sky pointed at
    /// its distribution in `light_distributions` and fitted to the
    /// render's MIS compensation.
    emitters: Vec<Emitter>,
    /// Sampling distributions that `emitters` refer to by index (one per
    /// `envmap` and `preetham` sky).
    light_distributions: Vec<Distribution2D>,
    /// Chooses emitters for next-event estimation.
    light_sampler: LightSampler,
    /// With portals, per world, the chooser among its own emitters
    /// (`scene/worlds.rs`); empty without.
    world_light_samplers: Vec<LightSampler>,
    /// With portals, per world, the ways its next-event estimation looks:
    /// those into worlds that have a light to choose.
    light_views: Vec<Vec<LightView>>,
    /// Per BSDF and per emitter, what the path tracer shades and samples
    /// eight at a time.
    wide: WideTables,
}

impl RenderState {
    /// The state of a render of `scene` with `integrator`.
    pub fn new(scene: &Scene, integrator: &dyn Integrator) -> Self {
        Self::with_lights(scene, LightOptions::of(integrator))
    }

    /// The state of a render of `scene` that chooses and samples lights
    /// as `lights` says.
    pub fn with_lights(scene: &Scene, lights: LightOptions) -> Self {
        let compensated = Self::compensated_emitters(scene, lights.mis_compensation);
        let mut emitters = scene.emitters.clone();
        let light_distributions =
            Self::build_light_distributions(scene, &mut emitters, &compensated);
        let build = |world| {
            Self::build_light_sampler(
                scene,
                lights.selection,
                &emitters,
                &compensated,
                &light_distributions,
                world,
            )
        };
        let light_sampler = build(None);
        let world_light_samplers = match scene.has_portals() {
            true => (0..scene.worlds.len() as u32)
                .map(|w| build(Some(w)))
                .collect(),
            false => Vec::new(),
        };
        let light_views = Self::light_views(scene, &world_light_samplers);
        Self {
            emitters,
            light_distributions,
            light_sampler,
            world_light_samplers,
            light_views,
            wide: WideTables::new(scene),
        }
    }

    /// Per world, the ways next-event estimation looks: at its own
    /// emitters and through its portal sides that keep angles, each into
    /// a world whose sampler (in `samplers`) has a light to choose.
    fn light_views(scene: &Scene, samplers: &[LightSampler]) -> Vec<Vec<LightView>> {
        let lit = |w: u32| samplers.get(w as usize).is_some_and(|s| !s.is_empty());
        (0..samplers.len() as u32)
            .map(|w| {
                let own = lit(w).then_some(LightView::Own);
                let through = (scene.lit_sides(w).iter())
                    .filter(|&&side| scene.portal_of(side).is_some_and(|p| lit(p.to_world)))
                    .map(|&side| LightView::Through(side));
                own.into_iter().chain(through).collect()
            })
            .collect()
    }

    /// The emitters as the render samples them (the scene's, in its order).
    pub fn emitters(&self) -> &[Emitter] {
        &self.emitters
    }

    /// The sampling distributions the render's emitters refer to.
    pub fn light_distributions(&self) -> &[Distribution2D] {
        &self.light_distributions
    }

    /// The light sampler.
    pub fn light_sampler(&self) -> &LightSampler {
        &self.light_sampler
    }

    /// Per emitter, whether light sampling may leave to BSDF sampling the
    /// light it finds well (`mis_compensation`, the integrator's). Emitters
    /// hidden from indirect rays cannot be found by BSDF sampling: light
    /// sampling must cover them whole.
    fn compensated_emitters(scene: &Scene, mis_compensation: bool) -> Vec<bool> {
        (scene.emitter_options.iter())
            .map(|o| mis_compensation && o.visible_indirect)
            .collect()
    }

    /// The sampling distributions of the emitters that need one (one per
    /// `envmap` and `preetham` sky), which `emitters` (the render's copies
    /// of the scene's) then refer to by index.
    fn build_light_distributions(
        scene: &Scene,
        emitters: &mut [Emitter],
        compensated: &[bool],
    ) -> Vec<Distribution2D> {
        crate::light::build_distributions(emitters, &scene.materials, compensated, scene.shutter)
    }

    /// The light sampler over `emitters` (the render's), in `scene` (its
    /// bounding sphere, or a unit one when it has no geometry, sets the
    /// scale of the light BVH).
    fn build_light_sampler(
        scene: &Scene,
        selection: LightSelection,
        emitters: &[Emitter],
        compensated: &[bool],
        distributions: &[Distribution2D],
        world: Option<u32>,
    ) -> LightSampler {
        let bounds = scene.bounds();
        let radius = if bounds.is_empty() {
            1.0
        } else {
            0.5 * bounds.extent().length()
        };
        let left_out = (emitters.iter().enumerate())
            .map(|(i, e)| {
                left_to_bsdf_sampling(e, compensated[i])
                    || world.is_some_and(|w| scene.emitter_world(i as u32) != w)
            })
            .collect();
        LightSampler::leaving_out(
            selection,
            emitters,
            &scene.emitter_options,
            left_out,
            &EmitterContext {
                shapes: &scene.shapes,
                meshes: &scene.meshes,
                images: &scene.materials.images,
                materials: &scene.materials,
                distributions,
                time: scene.shutter.open,
            },
            radius,
        )
    }
}

/// The scene as a render's integrator sees it: the [`Scene`] (which it
/// dereferences to) and the render's [`RenderState`], built from that
/// scene, at the time of one camera sample. Two references and the time,
/// passed by reference.
#[derive(Clone, Copy, Debug)]
pub struct RenderScene<'a> {
    scene: &'a Scene,
    state: &'a RenderState,
    time: f32,
}

impl std::ops::Deref for RenderScene<'_> {
    type Target = Scene;
    #[inline(always)]
    fn deref(&self) -> &Scene {
        self.scene
    }
}

impl<'a> RenderScene<'a> {
    /// `scene` with `state`, which must have been built from it.
    /// At the time the shutter opens.
    pub fn new(scene: &'a Scene, state: &'a RenderState) -> Self {
        Self {
            scene,
            state,
            time: scene.shutter.open,
        }
    }

    /// The same scene at `time` (what emitters that change with time,
    /// `timed_sunsky`, show).
    #[inline]
    pub fn at_time(self, time: f32) -> Self {
        Self { time, ..self }
    }

    /// The time of the camera sample.
    #[inline]
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Whether camera samples must be taken at times of their own: the
    /// shutter is open over an interval and some emitter changes with
    /// time.
    pub fn samples_times(&self) -> bool {
        self.scene.shutter.is_open() && self.state.emitters.iter().any(|e| e.changes_with_time())
    }

    /// The scene.
    #[inline]
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The render's state.
    #[inline]
    pub fn state(&self) -> &'a RenderState {
        self.state
    }

    /// What emitters need to see of the scene and the render.
    #[inline]
    pub fn emitter_context(&self) -> EmitterContext<'a> {
        let scene = self.scene;
        EmitterContext {
            shapes: &scene.shapes,
            meshes: &scene.meshes,
            images: &scene.materials.images,
            materials: &scene.materials,
            distributions: &self.state.light_distributions,
            time: self.time,
        }
    }

    /// Emitter `emitter` as the render samples it (with
    /// [`RenderScene::emitter_context`]).
    #[inline]
    pub fn emitter(&self, emitter: u32) -> &'a Emitter {
        &self.state.emitters[emitter as usize]
    }

    /// The light sampler.
    #[inline]
    pub fn light_sampler(&self) -> &'a LightSampler {
        &self.state.light_sampler
    }

    /// Chooses a light for next-event estimation at `p` (surface normal
    /// `n`, or zero); returns it and its probability.
    #[inline]
    pub fn pick_light(&self, u: f32, p: glam::Vec3, n: glam::Vec3) -> Option<(LightChoice, f32)> {
        self.state.light_sampler.sample(u, p, n)
    }

    /// [`RenderScene::pick_light`] among the emitters of world `world`
    /// alone (all of them in a scene without portals).
    #[inline]
    pub fn pick_light_in(
        &self,
        world: u32,
        u: f32,
        p: glam::Vec3,
        n: glam::Vec3,
    ) -> Option<(LightChoice, f32)> {
        self.light_sampler_of(world).sample(u, p, n)
    }

    /// Probability that [`RenderScene::pick_light_in`] `world` at (`p`,
    /// `n`) chooses `light`.
    #[inline]
    pub fn light_pmf_in(
        &self,
        world: u32,
        light: LightChoice,
        p: glam::Vec3,
        n: glam::Vec3,
    ) -> f32 {
        self.light_sampler_of(world).pmf(light, p, n)
    }

    /// The ways next-event estimation at a vertex in world `world` looks
    /// (empty without portals; see `scene/worlds.rs`).
    #[inline]
    pub fn light_views(&self, world: u32) -> &'a [LightView] {
        self.state
            .light_views
            .get(world as usize)
            .map_or(&[][..], Vec::as_slice)
    }

    /// The chooser among world `world`'s emitters.
    #[inline]
    fn light_sampler_of(&self, world: u32) -> &'a LightSampler {
        (self.state.world_light_samplers.get(world as usize)).unwrap_or(&self.state.light_sampler)
    }

    /// Probability that [`RenderScene::pick_light`] at (`p`, `n`) chooses
    /// `light`.
    #[inline]
    pub fn light_pmf(&self, light: LightChoice, p: glam::Vec3, n: glam::Vec3) -> f32 {
        self.state.light_sampler.pmf(light, p, n)
    }

    /// The light a hit on an emitting surface is, as the light sampler
    /// counts lights (the triangle, when it chooses them one by one).
    #[inline]
    pub fn light_of_hit(&self, si: &SurfaceInteraction) -> Option<LightChoice> {
        let emitter = self.scene.shape_info[si.shape as usize].emitter?;
        let prim = if self.state.light_sampler.splits(emitter) {
            si.prim
        } else {
            LightChoice::WHOLE
        };
        Some(LightChoice { emitter, prim })
    }

    /// Emitter `emitter`, when it is an area light of constant radiance on
    /// a rectangle.
    #[inline]
    pub(crate) fn rectangle_light(&self, emitter: u32) -> Option<&'a RectangleLight> {
        self.state.wide.rectangle_light(emitter)
    }

    /// The reflectances of a shape's BSDF, when it is a `diffuse` of
    /// constant reflectance (alone or in `twosided`).
    #[inline]
    pub(crate) fn diffuse_sides_of(&self, shape: u32) -> Option<DiffuseSides> {
        let bsdf = self.scene.shape_info[shape as usize].bsdf;
        self.state.wide.diffuse_sides(bsdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::PathIntegrator;
    use crate::light::{ConstantLight, EmitterModel, EnvMapLight, PointLight};
    use crate::texture::image::ImageData;
    use crate::texture::TexImage;
    use crate::{Rgb, SceneBuilder};
    use glam::{Mat3, Vec3};

    /// A point light, a constant sky and an environment map.
    fn lit_scene() -> Scene {
        let mut b = SceneBuilder::new();
        b.add_emitter(Emitter::Point(PointLight {
            position: Vec3::new(0.0, 2.0, 0.0),
            intensity: Rgb::splat(3.0),
        }));
        b.add_emitter(Emitter::Constant(ConstantLight {
            radiance: Rgb::splat(0.2),
        }));
        let texels: Vec<f32> = (0..8 * 4 * 3).map(|i| 0.1 + (i % 7) as f32).collect();
        let image = TexImage::new(8, 4, 3, ImageData::F32(texels), false).unwrap();
        let image = b.add_image(image);
        b.add_emitter(Emitter::EnvMap(EnvMapLight::new(
            image,
            1.0,
            Mat3::IDENTITY,
            None,
        )));
        b.build().unwrap()
    }

    /// The state follows the light options its integrator states, and
    /// leaves the scene's emitters as the scene describes them: only the
    /// render's copies refer to its distributions.
    #[test]
    fn state_follows_the_integrator_and_leaves_the_scene_alone() {
        let scene = lit_scene();
        let path = |selection, mis_compensation| PathIntegrator {
            light_selection: Some(selection),
            mis_compensation,
            ..PathIntegrator::default()
        };
        for (selection, compensated) in [
            (LightSelection::Power, true),
            (LightSelection::Uniform, false),
            (LightSelection::Bvh, true),
        ] {
            let integrator = path(selection, compensated);
            let state = RenderState::new(&scene, &integrator);
            assert_eq!(
                LightOptions::of(&integrator),
                LightOptions {
                    selection,
                    mis_compensation: compensated
                }
            );
            let render = RenderScene::new(&scene, &state);
            assert_eq!(render.light_sampler().selection, selection);
            // Under compensation the constant sky is left to BSDF sampling.
            assert_eq!(render.light_sampler().never_chooses(1), compensated);
            assert_eq!(state.light_distributions().len(), 1);
            let (Emitter::EnvMap(described), Emitter::EnvMap(sampled)) =
                (scene.emitters[2], *render.emitter(2))
            else {
                panic!("emitter 2 is the environment map");
            };
            assert_eq!(described.distribution, u32::MAX);
            assert_eq!(described.mis_compensation, None);
            assert_eq!(sampled.distribution, 0);
            assert_eq!(sampled.mis_compensation, Some(compensated));
            let ctx = render.emitter_context();
            let s = render
                .emitter(2)
                .sample_direction(&ctx, Vec3::ZERO, glam::Vec2::new(0.3, 0.6))
                .unwrap();
            assert!(s.pdf > 0.0);
        }
        // An integrator that states no selection gets the default.
        let state = RenderState::new(&scene, &PathIntegrator::default());
        assert_eq!(state.light_sampler().selection, LightSelection::default());
    }

    /// What integrators receive is two references and the time (padded to
    /// a third word).
    #[test]
    fn a_render_scene_is_two_pointers_and_a_time() {
        assert_eq!(
            std::mem::size_of::<RenderScene>(),
            3 * std::mem::size_of::<usize>()
        );
    }
}
