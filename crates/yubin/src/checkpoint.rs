//! Checkpoints of a render in passes: what it has accumulated
//! ([`PassState`]) and what it was asked to render (a fingerprint of the
//! scene file and the settings), written atomically; a resume compares
//! the fingerprint with the new command and says what differs.
//!
//! The file: a line `YUBIN-CHECKPOINT 2`, `key=value` lines (the
//! fingerprint), an empty line, then little-endian binary: samples per
//! pixel done (u32), passes (u32), dropped samples (u64), and the four
//! arrays of [`PassState`] each as a u64 length and its values, then an
//! FNV-1a hash (u64) of everything before it.

use anyhow::{bail, Context, Result};
use std::path::Path;
use yubin_core::render::PassState;

const MAGIC: &str = "YUBIN-CHECKPOINT 2";

/// What a render was asked to do, as `(key, value)` pairs.
pub type Fingerprint = Vec<(String, String)>;

/// FNV-1a, 64 bit: a content hash for the scene file and the checkpoint.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Writes the checkpoint (to a temporary file renamed into place).
pub fn write(path: &Path, fingerprint: &Fingerprint, state: &PassState) -> Result<()> {
    let mut bytes = format!("{MAGIC}\n").into_bytes();
    for (k, v) in fingerprint {
        bytes.extend(format!("{k}={}\n", v.replace('\n', " ")).as_bytes());
    }
    bytes.push(b'\n');
    bytes.extend(state.done.to_le_bytes());
    bytes.extend(state.passes.to_le_bytes());
    bytes.extend(state.dropped.to_le_bytes());
    let put_len = |bytes: &mut Vec<u8>, n: usize| bytes.extend((n as u64).to_le_bytes());
    put_len(&mut bytes, state.sums.len());
    state
        .sums
        .iter()
        .for_each(|v| bytes.extend(v.to_le_bytes()));
    put_len(&mut bytes, state.halves.len());
    state
        .halves
        .iter()
        .for_each(|v| bytes.extend(v.to_le_bytes()));
    put_len(&mut bytes, state.counts.len());
    state
        .counts
        .iter()
        .for_each(|v| bytes.extend(v.to_le_bytes()));
    put_len(&mut bytes, state.active.len());
    bytes.extend(state.active.iter().map(|&a| u8::from(a)));
    let hash = fnv1a(&bytes);
    bytes.extend(hash.to_le_bytes());
    let tmp = path.with_extension("state.tmp");
    std::fs::write(&tmp, &bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Reads a checkpoint; a file that is not one, or is damaged, is an error
/// that says so.
pub fn read(path: &Path) -> Result<(Fingerprint, PassState)> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let corrupt =
        |why: &str| anyhow::anyhow!("{}: not a usable checkpoint ({why})", path.display());
    if !bytes.starts_with(MAGIC.as_bytes()) {
        return Err(corrupt("it does not start with \"YUBIN-CHECKPOINT 2\": not a checkpoint, or one of an older yubin"));
    }
    if bytes.len() < 8 {
        return Err(corrupt("truncated"));
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    if fnv1a(body) != u64::from_le_bytes(tail.try_into().expect("8 bytes")) {
        return Err(corrupt(
            "its contents do not match their checksum: damaged or truncated",
        ));
    }
    let header_end = body
        .windows(2)
        .position(|w| w == b"\n\n")
        .ok_or_else(|| corrupt("no end of header"))?;
    let header = std::str::from_utf8(&body[..header_end]).map_err(|_| corrupt("bad header"))?;
    let fingerprint = header
        .lines()
        .skip(1)
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut r = Reader {
        bytes: &body[header_end + 2..],
    };
    let mut state = PassState {
        done: r.u32().ok_or_else(|| corrupt("truncated"))?,
        passes: r.u32().ok_or_else(|| corrupt("truncated"))?,
        dropped: r.u64().ok_or_else(|| corrupt("truncated"))?,
        sums: Vec::new(),
        halves: Vec::new(),
        counts: Vec::new(),
        active: Vec::new(),
    };
    state.sums = r
        .array(4, |b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
        .ok_or_else(|| corrupt("truncated"))?;
    state.halves = r
        .array(4, |b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
        .ok_or_else(|| corrupt("truncated"))?;
    state.counts = r
        .array(4, |b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
        .ok_or_else(|| corrupt("truncated"))?;
    state.active = r
        .array(1, |b| b[0] != 0)
        .ok_or_else(|| corrupt("truncated"))?;
    Ok((fingerprint, state))
}

/// Refuses to resume when what the checkpoint was made for differs from
/// what this command asks, naming each difference.
pub fn check_same(path: &Path, saved: &Fingerprint, now: &Fingerprint) -> Result<()> {
    let differences = differences(saved, now, ("then", "now"));
    if !differences.is_empty() {
        bail!(
            "{} was made for another render; it differs in {}",
            path.display(),
            differences.join("; ")
        );
    }
    Ok(())
}

/// The keys whose values differ between fingerprints `a` and `b`, each
/// with both values, labelled by `labels` (`spp: "8" then, "9" now`).
pub fn differences(a: &Fingerprint, b: &Fingerprint, labels: (&str, &str)) -> Vec<String> {
    let value = |f: &Fingerprint, k: &str| {
        f.iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| "(none)".into())
    };
    let mut keys: Vec<&String> = a.iter().chain(b).map(|(k, _)| k).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter_map(|k| {
            let (x, y) = (value(a, k), value(b, k));
            (x != y).then(|| format!("{k}: \"{x}\" {}, \"{y}\" {}", labels.0, labels.1))
        })
        .collect()
}

struct Reader<'a> {
    bytes: &'a [u8],
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        if self.bytes.len() < n {
            return None;
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Some(head)
    }

    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }

    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    fn array<T>(&mut self, size: usize, read: impl Fn(&[u8]) -> T) -> Option<Vec<T>> {
        let n = usize::try_from(self.u64()?).ok()?;
        let data = self.take(n.checked_mul(size)?)?;
        Some(data.chunks_exact(size).map(read).collect())
    }
}
