//! The BSDF at one surface vertex: what a [`Material`] yields once its
//! textures have been read at the hit ([`Material::at`]).
//!
//! A material is what a scene file describes: parameters that may be
//! textures, and composites (`twosided`, `mask`, `blendbsdf`, `bumpmap`,
//! `normalmap`) that refer to other materials by index. At a vertex the
//! integrator asks it once for a [`Bsdf`]: a plain `Copy` value with no
//! reference into the scene, whose `sample`, `eval`, `pdf` and `eval_pdf`
//! serve every query there (the light sample and the BSDF sample).
//!
//! - A single model is one [`Lobe`]: the model's formulas with its
//!   textures replaced by their values at the hit (and, where a model has
//!   terms that depend on `wo` alone, those terms).
//! - A composite is resolved into a small [`Tree`] of nodes over at most
//!   [`MAX_LOBES`] lobes: `twosided` has already picked the side `wo` is
//!   on (a mirror node when it is the back), `mask` and `blendbsdf` hold
//!   their opacity and weight, and bump and normal maps the perturbed
//!   frame chosen for `wo`. The nodes compute what the composites computed
//!   query by query, in the same order, so a material gives the same
//!   values, densities and samples through its [`Bsdf`] bit for bit.
//!
//! Composites nest at most [`MAX_NODES`] deep in all; a scene asking for
//! more is refused at load ([`Material::tree_size`]).

use super::{
    blend_bsdf::BlendNode, mask::MaskNode, perturbed::PerturbedNode, twosided::mirror, BsdfContext,
    BsdfSample, Material,
};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::Rgb;
use glam::{Vec2, Vec3};

pub use super::conductor::ConductorLobe;
pub use super::dielectric::DielectricLobe;
pub use super::difftrans::DiffTransLobe;
pub use super::diffuse::DiffuseLobe;
pub use super::hair::HairLobe;
pub use super::measured::MeasuredLobe;
pub use super::phong::PhongLobe;
pub use super::plastic::PlasticLobe;
pub use super::principled::PrincipledLobe;
pub use super::principled_thin::PrincipledThinLobe;
pub use super::rough_conductor::RoughConductorLobe;
pub use super::rough_dielectric::RoughDielectricLobe;
pub use super::rough_diffuse::RoughDiffuseLobe;
pub use super::rough_plastic::RoughPlasticLobe;
pub use super::thin_dielectric::ThinDielectricLobe;

/// Most nodes a resolved composite may have.
pub const MAX_NODES: usize = 16;
/// Most single models a resolved composite may hold.
pub const MAX_LOBES: usize = 8;

/// The queries every lobe answers, for directions in the local shading
/// frame (see the conventions in the module docs of [`crate::bsdf`]).
pub trait Scatter {
    /// Samples `wi` given `wo`; `u1` picks a lobe, `u2` the direction.
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample>;
    /// f · |cos θi| for the smooth lobes (delta lobes give 0).
    fn eval(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb;
    /// Density with which [`Scatter::sample`] picks `wi` (smooth lobes).
    fn pdf(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32;
    /// [`Scatter::eval`] and [`Scatter::pdf`] at once, as a light sample
    /// weighed by MIS needs them; the same values, with the work they
    /// share (half vector, D, G1 of `wo`) done once where a model
    /// overrides it.
    #[inline]
    fn eval_pdf(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        (self.eval(ctx, wo, wi), self.pdf(ctx, wo, wi))
    }
}

/// One model with its textures read at a vertex (closed enum).
#[derive(Clone, Copy, Debug)]
pub enum Lobe {
    /// Scatters nothing: a one-sided model seen from below where that is
    /// known at the vertex, a perturbed frame `wo` cannot see.
    Black,
    /// `null`: only the index-matched pass-through.
    Null,
    /// `diffuse`.
    Diffuse(DiffuseLobe),
    /// `plastic`.
    Plastic(PlasticLobe),
    /// `roughplastic`.
    RoughPlastic(RoughPlasticLobe),
    /// `dielectric`.
    Dielectric(DielectricLobe),
    /// `thindielectric`.
    ThinDielectric(ThinDielectricLobe),
    /// `roughdielectric`.
    RoughDielectric(RoughDielectricLobe),
    /// `conductor`.
    Conductor(ConductorLobe),
    /// `roughconductor`.
    RoughConductor(RoughConductorLobe),
    /// `principled`.
    Principled(PrincipledLobe),
    /// `principledthin`.
    PrincipledThin(PrincipledThinLobe),
    /// `roughdiffuse`.
    RoughDiffuse(RoughDiffuseLobe),
    /// `phong`.
    Phong(PhongLobe),
    /// `difftrans`.
    DiffTrans(DiffTransLobe),
    /// `measured`.
    Measured(MeasuredLobe),
    /// `hair`.
    Hair(HairLobe),
}

macro_rules! dispatch_lobe {
    ($self:expr, $l:ident => $e:expr, black => $b:expr, null => $n:expr) => {
        match $self {
            Lobe::Black => $b,
            Lobe::Null => $n,
            Lobe::Diffuse($l) => $e,
            Lobe::Plastic($l) => $e,
            Lobe::RoughPlastic($l) => $e,
            Lobe::Dielectric($l) => $e,
            Lobe::ThinDielectric($l) => $e,
            Lobe::RoughDielectric($l) => $e,
            Lobe::Conductor($l) => $e,
            Lobe::RoughConductor($l) => $e,
            Lobe::Principled($l) => $e,
            Lobe::PrincipledThin($l) => $e,
            Lobe::RoughDiffuse($l) => $e,
            Lobe::Phong($l) => $e,
            Lobe::DiffTrans($l) => $e,
            Lobe::Measured($l) => $e,
            Lobe::Hair($l) => $e,
        }
    };
}

impl Scatter for Lobe {
    #[inline]
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        dispatch_lobe!(self, l => l.sample(ctx, wo, u1, u2), black => None,
            null => Some(super::null::pass_through(wo)))
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        dispatch_lobe!(self, l => l.eval(ctx, wo, wi), black => Rgb::ZERO, null => Rgb::ZERO)
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        dispatch_lobe!(self, l => l.pdf(ctx, wo, wi), black => 0.0, null => 0.0)
    }
    #[inline]
    fn eval_pdf(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        dispatch_lobe!(self, l => l.eval_pdf(ctx, wo, wi), black => (Rgb::ZERO, 0.0),
            null => (Rgb::ZERO, 0.0))
    }
}

/// A node of a resolved composite; children by index into [`Tree`].
#[derive(Clone, Copy, Debug)]
pub(super) enum Node {
    /// A single model, by index into the tree's lobes.
    Leaf(u8),
    /// `twosided` seen from the back: the child sees both directions
    /// mirrored to its front.
    Mirror(u8),
    /// `mask`.
    Mask(MaskNode),
    /// `blendbsdf`.
    Blend(BlendNode),
    /// `bumpmap` or `normalmap`.
    Perturbed(PerturbedNode),
}

/// A composite resolved at a vertex: its nodes (the root last pushed, at
/// `root`) over its single models.
#[derive(Clone, Copy, Debug)]
pub struct Tree {
    nodes: [Node; MAX_NODES],
    lobes: [Lobe; MAX_LOBES],
    n_nodes: u8,
    n_lobes: u8,
    root: u8,
}

/// Index of "no node": what a composite beyond the capacity resolves to
/// (refused at load, so never reached by a scene that loaded).
const NONE: u8 = u8::MAX;

impl Tree {
    fn new() -> Self {
        Self {
            nodes: [Node::Leaf(0); MAX_NODES],
            lobes: [Lobe::Black; MAX_LOBES],
            n_nodes: 0,
            n_lobes: 0,
            root: NONE,
        }
    }

    fn push(&mut self, node: Node) -> u8 {
        if self.n_nodes as usize == MAX_NODES {
            return NONE;
        }
        self.nodes[self.n_nodes as usize] = node;
        self.n_nodes += 1;
        self.n_nodes - 1
    }

    fn push_lobe(&mut self, lobe: Lobe) -> u8 {
        if self.n_lobes as usize == MAX_LOBES {
            return NONE;
        }
        self.lobes[self.n_lobes as usize] = lobe;
        self.n_lobes += 1;
        self.push(Node::Leaf(self.n_lobes - 1))
    }

    /// Resolves `b` at `si` seen from `wo`, returning its node.
    fn resolve(&mut self, b: &Material, m: &Materials, si: &SurfaceInteraction, wo: Vec3) -> u8 {
        let nested = |i: u32| &m.bsdfs[i as usize];
        match b {
            Material::TwoSided(t) => {
                let (side, back) = t.side(wo);
                if back {
                    let child = self.resolve(nested(side), m, si, mirror(wo));
                    self.push_if(child, Node::Mirror(child))
                } else {
                    self.resolve(nested(side), m, si, wo)
                }
            }
            Material::Mask(b) => {
                let child = self.resolve(nested(b.nested), m, si, wo);
                self.push_if(child, Node::Mask(MaskNode::new(b.alpha(m, si), child)))
            }
            Material::BlendBsdf(b) => {
                let w = b.w(m, si);
                let first = self.resolve(nested(b.bsdfs[0]), m, si, wo);
                let second = self.resolve(nested(b.bsdfs[1]), m, si, wo);
                if second == NONE {
                    return NONE;
                }
                self.push_if(first, Node::Blend(BlendNode::new(w, [first, second])))
            }
            Material::BumpMap(b) => self.perturbed(b.perturbation(m, si), b.nested, m, si, wo),
            Material::NormalMap(b) => self.perturbed(b.perturbation(m, si), b.nested, m, si, wo),
            leaf => self.push_lobe(leaf.leaf_lobe(m, si, wo)),
        }
    }

    fn perturbed(
        &mut self,
        p: super::perturbed::Perturbation,
        nested: u32,
        m: &Materials,
        si: &SurfaceInteraction,
        wo: Vec3,
    ) -> u8 {
        match PerturbedNode::for_view(&p, wo) {
            Some((node, wo_p)) => {
                let child = self.resolve(&m.bsdfs[nested as usize], m, si, wo_p);
                self.push_if(child, Node::Perturbed(node.with_child(child)))
            }
            None => self.push_lobe(Lobe::Black),
        }
    }

    fn push_if(&mut self, child: u8, node: Node) -> u8 {
        if child == NONE {
            NONE
        } else {
            self.push(node)
        }
    }

    /// [`Scatter::sample`] of node `n`.
    pub(super) fn sample(
        &self,
        n: u8,
        ctx: &BsdfContext,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        match *self.nodes.get(n as usize)? {
            Node::Leaf(l) => self.lobes[l as usize].sample(ctx, wo, u1, u2),
            Node::Mirror(c) => self.sample(c, ctx, mirror(wo), u1, u2).map(|s| BsdfSample {
                wi: mirror(s.wi),
                ..s
            }),
            Node::Mask(k) => k.sample(self, ctx, wo, u1, u2),
            Node::Blend(k) => k.sample(self, ctx, wo, u1, u2),
            Node::Perturbed(k) => k.sample(self, ctx, wo, u1, u2),
        }
    }

    /// [`Scatter::eval`] of node `n`.
    pub(super) fn eval(&self, n: u8, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        match self.nodes.get(n as usize) {
            None => Rgb::ZERO,
            Some(Node::Leaf(l)) => self.lobes[*l as usize].eval(ctx, wo, wi),
            Some(Node::Mirror(c)) => self.eval(*c, ctx, mirror(wo), mirror(wi)),
            Some(Node::Mask(k)) => k.eval(self, ctx, wo, wi),
            Some(Node::Blend(k)) => k.eval(self, ctx, wo, wi),
            Some(Node::Perturbed(k)) => k.eval(self, ctx, wo, wi),
        }
    }

    /// [`Scatter::pdf`] of node `n`.
    pub(super) fn pdf(&self, n: u8, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        match self.nodes.get(n as usize) {
            None => 0.0,
            Some(Node::Leaf(l)) => self.lobes[*l as usize].pdf(ctx, wo, wi),
            Some(Node::Mirror(c)) => self.pdf(*c, ctx, mirror(wo), mirror(wi)),
            Some(Node::Mask(k)) => k.pdf(self, ctx, wo, wi),
            Some(Node::Blend(k)) => k.pdf(self, ctx, wo, wi),
            Some(Node::Perturbed(k)) => k.pdf(self, ctx, wo, wi),
        }
    }

    /// [`Scatter::eval_pdf`] of node `n`.
    pub(super) fn eval_pdf(&self, n: u8, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        match self.nodes.get(n as usize) {
            None => (Rgb::ZERO, 0.0),
            Some(Node::Leaf(l)) => self.lobes[*l as usize].eval_pdf(ctx, wo, wi),
            Some(Node::Mirror(c)) => self.eval_pdf(*c, ctx, mirror(wo), mirror(wi)),
            Some(Node::Mask(k)) => k.eval_pdf(self, ctx, wo, wi),
            Some(Node::Blend(k)) => k.eval_pdf(self, ctx, wo, wi),
            Some(Node::Perturbed(k)) => k.eval_pdf(self, ctx, wo, wi),
        }
    }
}

/// What the BSDF at a vertex is made of. The tree is large and kept
/// inline (no allocation per vertex); a single model writes only its lobe.
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)]
enum Resolved {
    /// A single model (the common case, kept small).
    One(Lobe),
    /// A composite.
    Tree(Tree),
}

/// The BSDF at one vertex, seen from `wo` (local): texture-free, `Copy`,
/// answering every query at the vertex (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    wo: Vec3,
    resolved: Resolved,
}

impl Material {
    /// The BSDF of this material at `si`, seen from the local direction
    /// `wo`: its textures read once, composites resolved.
    #[inline]
    pub fn at(&self, m: &Materials, si: &SurfaceInteraction, wo: Vec3) -> Bsdf {
        if self.is_composite() {
            return self.composite_at(m, si, wo);
        }
        Bsdf {
            wo,
            resolved: Resolved::One(self.leaf_lobe(m, si, wo)),
        }
    }

    /// [`Material::at`] of a composite (kept out of the integrators'
    /// loops, where single models are the rule).
    #[inline(never)]
    fn composite_at(&self, m: &Materials, si: &SurfaceInteraction, wo: Vec3) -> Bsdf {
        let mut tree = Tree::new();
        tree.root = tree.resolve(self, m, si, wo);
        Bsdf {
            wo,
            resolved: Resolved::Tree(tree),
        }
    }

    /// Whether this material refers to others (and resolves to a tree).
    #[inline]
    pub fn is_composite(&self) -> bool {
        matches!(
            self,
            Material::TwoSided(_)
                | Material::Mask(_)
                | Material::BlendBsdf(_)
                | Material::BumpMap(_)
                | Material::NormalMap(_)
        )
    }

    /// The most (nodes, lobes) this material resolves to at any vertex,
    /// for the check against [`MAX_NODES`] and [`MAX_LOBES`] at load.
    pub fn tree_size(&self, m: &Materials) -> (usize, usize) {
        let nested = |i: u32| m.bsdfs.get(i as usize).map_or((1, 1), |b| b.tree_size(m));
        let plus_one = |(n, l): (usize, usize)| (n + 1, l);
        match self {
            Material::TwoSided(t) => {
                let ((nf, lf), (nb, lb)) = (nested(t.front), nested(t.back));
                (nf.max(nb + 1), lf.max(lb))
            }
            Material::Mask(b) => plus_one(nested(b.nested)),
            Material::BumpMap(b) => plus_one(nested(b.nested)),
            Material::NormalMap(b) => plus_one(nested(b.nested)),
            Material::BlendBsdf(b) => {
                let ((na, la), (nb, lb)) = (nested(b.bsdfs[0]), nested(b.bsdfs[1]));
                (na + nb + 1, la + lb)
            }
            _ => (1, 1),
        }
    }
}

impl Bsdf {
    /// The direction the BSDF was made for.
    #[inline]
    pub fn wo(&self) -> Vec3 {
        self.wo
    }

    /// Samples `wi`; `u1` picks a lobe, `u2` the direction.
    #[inline]
    pub fn sample(&self, ctx: &BsdfContext, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        match &self.resolved {
            Resolved::One(l) => l.sample(ctx, self.wo, u1, u2),
            Resolved::Tree(t) => t.sample(t.root, ctx, self.wo, u1, u2),
        }
    }

    /// f · |cos θi| towards `wi`.
    #[inline]
    pub fn eval(&self, ctx: &BsdfContext, wi: Vec3) -> Rgb {
        match &self.resolved {
            Resolved::One(l) => l.eval(ctx, self.wo, wi),
            Resolved::Tree(t) => t.eval(t.root, ctx, self.wo, wi),
        }
    }

    /// The density of sampling `wi`.
    #[inline]
    pub fn pdf(&self, ctx: &BsdfContext, wi: Vec3) -> f32 {
        match &self.resolved {
            Resolved::One(l) => l.pdf(ctx, self.wo, wi),
            Resolved::Tree(t) => t.pdf(t.root, ctx, self.wo, wi),
        }
    }

    /// [`Bsdf::eval`] and [`Bsdf::pdf`] at once.
    #[inline]
    pub fn eval_pdf(&self, ctx: &BsdfContext, wi: Vec3) -> (Rgb, f32) {
        match &self.resolved {
            Resolved::One(l) => l.eval_pdf(ctx, self.wo, wi),
            Resolved::Tree(t) => t.eval_pdf(t.root, ctx, self.wo, wi),
        }
    }

    /// The value towards `wi` and, when `with_pdf`, the density of
    /// sampling it ([`Bsdf::eval_pdf`]; else [`Bsdf::eval`] and 0).
    #[inline]
    pub fn eval_pdf_if(&self, ctx: &BsdfContext, wi: Vec3, with_pdf: bool) -> (Rgb, f32) {
        if with_pdf {
            self.eval_pdf(ctx, wi)
        } else {
            (self.eval(ctx, wi), 0.0)
        }
    }
}

// Node indices are u8, with NONE kept free (lobes are fewer than nodes).
const _: () = assert!(MAX_NODES < NONE as usize && MAX_LOBES <= MAX_NODES);

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::{MicrofacetType, Roughness};
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::{BlendBsdf, BumpMap, Diffuse, Mask, RoughDielectric, RoughPlastic, TwoSided};
    use crate::texture::Tex;

    /// The BSDF at a vertex is made at every bounce: a lobe stays a few
    /// cache lines, and a single model's BSDF writes no more than its lobe
    /// (the composite's tree is the rest of the value, left unwritten).
    #[test]
    fn the_values_stay_small() {
        assert!(
            std::mem::size_of::<Lobe>() <= 128,
            "{}",
            std::mem::size_of::<Lobe>()
        );
        assert!(
            std::mem::size_of::<Bsdf>() <= 2048,
            "{}",
            std::mem::size_of::<Bsdf>()
        );
    }

    /// Composites nested in composites, over a model whose lobe depends on
    /// `wo` (`roughplastic`): the tree must hand every lobe the `wo` it
    /// was made for, through the back side's mirror and the bump map's
    /// frame. For the table-driven tests in `bsdf/mod.rs`. (A mask inside
    /// a bump map is left out: its null samples are shadowed by the
    /// perturbation, which shadow rays crossing it do not see.)
    pub(crate) fn test_variants() -> Vec<Variant> {
        let plastic = Material::RoughPlastic(RoughPlastic::new(
            MicrofacetType::Ggx,
            0.3,
            Rgb::new(0.5, 0.3, 0.2),
            1.5,
            false,
        ));
        let glass = Material::RoughDielectric(RoughDielectric::new(
            1.5,
            Roughness::isotropic(MicrofacetType::Beckmann, 0.2, true),
        ));
        let mut v = Variant::last(
            "twosided (a mask over a bumpmap over a blend of a roughplastic and a \
             roughdielectric; roughplastic behind)",
            vec![
                plastic,
                glass,
                Material::BlendBsdf(BlendBsdf {
                    weight: Tex::value(0.4),
                    bsdfs: [0, 1],
                }),
                Material::BumpMap(BumpMap {
                    height: 0,
                    scale: 0.5,
                    nested: 2,
                }),
                Material::Mask(Mask {
                    opacity: Tex::value(0.7),
                    nested: 3,
                }),
                Material::TwoSided(TwoSided { front: 4, back: 0 }),
            ],
        );
        crate::bsdf::bump_map::tests::push_ramp_height(&mut v.m);
        // The bump map replaces the shading normal; the glass refracts.
        v.reciprocal = false;
        vec![v]
    }

    /// The nested variant resolves to the tree its size promises.
    #[test]
    fn a_nested_composite_resolves_to_its_size() {
        let v = test_variants().remove(0);
        let b = v.m.bsdfs[v.id];
        assert_eq!(b.tree_size(&v.m), (5, 2));
        let front = b.at(&v.m, &flat_si(), Vec3::new(0.3, 0.1, 0.9).normalize());
        let Resolved::Tree(t) = front.resolved else {
            panic!("a composite resolves to a tree")
        };
        assert_eq!((t.n_nodes, t.n_lobes), (5, 2));
        let back = b.at(&v.m, &flat_si(), Vec3::new(0.3, 0.1, -0.9).normalize());
        let Resolved::Tree(t) = back.resolved else {
            panic!("a composite resolves to a tree")
        };
        assert!(matches!(t.nodes[t.root as usize], Node::Mirror(_)));
        assert_eq!((t.n_nodes, t.n_lobes), (2, 1));
    }

    /// A blend of more single models than the tree holds: its size says so
    /// (and the scene builder refuses it), and were it asked anyway, the
    /// BSDF scatters nothing rather than failing.
    #[test]
    fn a_composite_too_large_scatters_nothing() {
        // Blend k mixes the diffuse and blend k − 1: k + 1 single models.
        let mut bsdfs = vec![Material::Diffuse(Diffuse::new(Rgb::splat(0.5)))];
        for i in 0..MAX_LOBES as u32 {
            bsdfs.push(Material::BlendBsdf(BlendBsdf {
                weight: Tex::value(0.5),
                bsdfs: [0, i],
            }));
        }
        let m = Materials::with_bsdfs(bsdfs);
        let top = m.bsdfs.last().unwrap();
        let (nodes, lobes) = top.tree_size(&m);
        assert!(lobes > MAX_LOBES, "{nodes} nodes, {lobes} lobes");
        let ctx = BsdfContext::default();
        let wo = Vec3::new(0.2, 0.1, 0.9).normalize();
        let b = top.at(&m, &flat_si(), wo);
        assert_eq!(b.eval(&ctx, Vec3::Z), Rgb::ZERO);
        assert_eq!(b.pdf(&ctx, Vec3::Z), 0.0);
        assert!(b.sample(&ctx, 0.5, Vec2::splat(0.5)).is_none());
    }
}
