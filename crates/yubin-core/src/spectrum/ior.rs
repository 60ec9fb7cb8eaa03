//! Named indices of refraction: the dielectrics `dielectric`,
//! `roughdielectric`, `thindielectric` (and the coated and plastic models)
//! accept for `int_ior` / `ext_ior`, and the conductors `conductor` and
//! `roughconductor` accept for `material`. The same names as Mitsuba 3.
//!
//! Dielectrics: single values near the sodium D line (589 nm), as listed in
//! Mitsuba 3's `dielectric` documentation, from the standard compilations
//! (CRC Handbook of Chemistry and Physics, "Index of refraction" tables;
//! Schott's N-BK7 data sheet for `bk7`). Conductors: eta and k in RGB, from
//! the measured spectra of Mitsuba's data set, converted by
//! `scripts/gen-ior-table.py` into `ior_table.rs`.

use super::ior_table::CONDUCTORS;
use super::Rgb;
use crate::params::{ParamError, Params};

/// Named dielectric IORs, in Mitsuba 3's order. Names are matched ignoring
/// case.
const DIELECTRICS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000_036),
    ("hydrogen", 1.000_132),
    ("air", 1.000_277),
    ("carbon dioxide", 1.000_45),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.520_45),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The names [`dielectric_ior`] knows, for error messages.
pub const DIELECTRIC_NAMES: &[&str] = &[
    "vacuum",
    "helium",
    "hydrogen",
    "air",
    "carbon dioxide",
    "water",
    "acetone",
    "ethanol",
    "carbon tetrachloride",
    "glycerol",
    "benzene",
    "silicone oil",
    "bromine",
    "water ice",
    "fused quartz",
    "pyrex",
    "acrylic glass",
    "polypropylene",
    "bk7",
    "sodium chloride",
    "amber",
    "pet",
    "diamond",
];

/// The IOR of a named dielectric (`"bk7"`, `"water"`, ...; case is
/// ignored), or `None` for a name not in [`DIELECTRIC_NAMES`].
pub fn dielectric_ior(name: &str) -> Option<f32> {
    DIELECTRICS
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|&(_, v)| v)
}

/// Reads a dielectric's index of refraction `name` (`int_ior`, `ext_ior`):
/// a float, or a name from [`DIELECTRIC_NAMES`] (or a number written as a
/// string); `default` (a name) when absent. It must be positive.
pub fn ior_from_params(p: &mut dyn Params, name: &str, default: &str) -> Result<f32, ParamError> {
    // Asked for as a float even when absent, so that a scene's parameters
    // list it (with its default) and an update can set it.
    let v = match p.float(name) {
        Ok(Some(v)) => v,
        Ok(None) => dielectric_ior(default).ok_or_else(|| p.param_error(name, "bad default"))?,
        // Not a number: a material's name.
        Err(not_float) => {
            let Ok(Some(s)) = p.string(name) else {
                return Err(not_float);
            };
            match (s.trim().parse::<f32>(), dielectric_ior(s.trim())) {
                (Ok(v), _) | (_, Some(v)) => v,
                _ => {
                    return Err(p.param_error(
                        name,
                        &format!(
                            "unknown material \"{s}\" (known: {}; or give a number)",
                            DIELECTRIC_NAMES.join(", ")
                        ),
                    ))
                }
            }
        }
    };
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(p.param_error(
            name,
            &format!("an index of refraction must be positive, not {v}"),
        ))
    }
}

/// The names [`conductor_ior`] knows (case matters, as in Mitsuba, whose
/// names are file names), for error messages.
pub const CONDUCTOR_NAMES: &[&str] = &{
    let mut names = [""; CONDUCTORS.len() + 1];
    let mut i = 0;
    while i < CONDUCTORS.len() {
        names[i] = CONDUCTORS[i].0;
        i += 1;
    }
    names[i] = "none";
    names
};

/// The complex IOR (eta, k) in RGB of a named conductor (`"Au"`, `"Cu"`,
/// `"Al"`, ...), or of `"none"`, a perfect mirror (eta 0, k 1); `None` for
/// a name not in [`CONDUCTOR_NAMES`].
pub fn conductor_ior(name: &str) -> Option<(Rgb, Rgb)> {
    if name == "none" {
        return Some((Rgb::ZERO, Rgb::ONE));
    }
    CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, eta, k)| (Rgb::from_array(eta), Rgb::from_array(k)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_dielectrics() {
        assert_eq!(dielectric_ior("bk7"), Some(1.5046));
        assert_eq!(dielectric_ior("BK7"), Some(1.5046));
        assert_eq!(dielectric_ior("water ice"), Some(1.31));
        assert_eq!(dielectric_ior("glass"), None);
        assert_eq!(DIELECTRIC_NAMES.len(), DIELECTRICS.len());
        for (n, (m, v)) in DIELECTRIC_NAMES.iter().zip(DIELECTRICS) {
            assert_eq!(n, m);
            assert!((1.0..2.5).contains(v), "{n}: {v}");
        }
        // Mitsuba's default dielectric is bk7 inside air.
        let eta = dielectric_ior("bk7").unwrap() / dielectric_ior("air").unwrap();
        assert!((eta - 1.504_183).abs() < 1e-6, "{eta}");
    }

    #[test]
    fn ior_parameters() {
        use crate::testing::params::{MapParams, Value};
        let mut p = MapParams::new()
            .with("int_ior", Value::String("Water".into()))
            .with("ext_ior", Value::Float(1.2))
            .with("x", Value::String("1.7".into()));
        assert_eq!(ior_from_params(&mut p, "int_ior", "bk7"), Ok(1.333));
        assert_eq!(ior_from_params(&mut p, "ext_ior", "air"), Ok(1.2));
        assert_eq!(ior_from_params(&mut p, "x", "air"), Ok(1.7));
        assert_eq!(ior_from_params(&mut p, "absent", "air"), Ok(1.000_277));
        assert!(p.unread().is_empty());
        let mut p = MapParams::new()
            .with("a", Value::String("glass".into()))
            .with("b", Value::Float(0.0))
            .with("c", Value::Float(-1.5))
            .with("d", Value::Bool(true));
        let e = ior_from_params(&mut p, "a", "bk7").unwrap_err().0;
        assert!(
            e.contains("unknown material \"glass\"") && e.contains("bk7, sodium chloride"),
            "{e}"
        );
        for n in ["b", "c"] {
            let e = ior_from_params(&mut p, n, "bk7").unwrap_err().0;
            assert!(e.contains("must be positive"), "{e}");
        }
        assert!(ior_from_params(&mut p, "d", "bk7").is_err());
    }

    /// The table against the values Mitsuba 3.9.1 (`scalar_rgb`) uses:
    /// printed by `mi.traverse(mi.load_dict({"type": "conductor",
    /// "material": name}))` (`eta.value`, `k.value`).
    #[test]
    fn conductors_match_mitsuba_rgb_mode() {
        let mitsuba = [
            (
                "Au",
                [0.143036, 0.375307, 1.44205],
                [3.983, 2.38556, 1.60336],
            ),
            (
                "Cu",
                [0.201005, 0.92375, 1.10222],
                [3.91326, 2.45305, 2.14209],
            ),
            ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
            (
                "Ag",
                [0.155276, 0.116728, 0.138388],
                [4.82835, 3.12222, 2.1469],
            ),
            ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
            (
                "W",
                [4.37082, 3.30025, 2.99841],
                [3.50064, 2.60487, 2.27323],
            ),
            (
                "a-C",
                [2.94405, 2.22714, 1.96816],
                [0.887465, 0.799299, 0.81529],
            ),
            (
                "Cu_palik",
                [0.213229, 0.919715, 1.10241],
                [3.92187, 2.45733, 2.13658],
            ),
            (
                "Hg",
                [2.39894, 1.44003, 0.90957],
                [6.32759, 4.37192, 3.42176],
            ),
        ];
        for (name, eta, k) in mitsuba {
            let (e, kk) = conductor_ior(name).unwrap();
            let de = (e - Rgb::from_array(eta)).abs().max_element();
            let dk = (kk - Rgb::from_array(k)).abs().max_element();
            assert!(de < 1e-4 && dk < 1e-4, "{name}: eta {e} k {kk}");
        }
        assert_eq!(conductor_ior("none"), Some((Rgb::ZERO, Rgb::ONE)));
        assert_eq!(conductor_ior("au"), None, "names are file names");
        assert_eq!(conductor_ior("gold"), None);
        assert_eq!(CONDUCTOR_NAMES.len(), 72);
        assert!(CONDUCTOR_NAMES.contains(&"Au") && CONDUCTOR_NAMES.contains(&"none"));
    }

    /// The shipped table is what the script makes from the data (run only
    /// where `../shared` and `python3` are; skipped with a reason otherwise).
    #[test]
    fn ior_table_is_regenerated_needs_shared() {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let data = format!("{root}/../shared/mitsuba-data/ior");
        if !std::path::Path::new(&data).is_dir() {
            println!("skipped: {data} is not there");
            return;
        }
        let Ok(out) = std::process::Command::new("python3")
            .arg(format!("{root}/scripts/gen-ior-table.py"))
            .arg(&data)
            .output()
        else {
            println!("skipped: no python3");
            return;
        };
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let shipped = include_str!("ior_table.rs");
        assert!(
            String::from_utf8_lossy(&out.stdout) == shipped,
            "spectrum/ior_table.rs is stale: rerun scripts/gen-ior-table.py"
        );
    }
}
