//! Embree's side: Intel Embree 3 (Debian bookworm's `libembree-dev`,
//! 3.13.5) through the `embree` crate 0.3.8's raw `embree::sys` bindings,
//! set up as raybench does.
//!
//! - One triangle geometry with the mesh copied into Embree-owned vertex
//!   and index buffers (before the timer), build quality MEDIUM (Embree's
//!   default), `rtcCommitScene` timed.
//! - 1-thread builds use a device created with `threads=1`; 2-thread builds
//!   a default device, which uses every core (2 here).
//! - Memory is what the device's memory monitor callback
//!   (`rtcSetDeviceMemoryMonitorFunction`) counts as retained by the
//!   commit: the BVH with its triangle leaf data, not the input buffers.
//! - Tracing is single-ray `rtcIntersect1` / `rtcOccluded1`, with the
//!   `RTCRayHit` filled from our ray inside the timed loop, and the
//!   context flagged COHERENT for primary rays, INCOHERENT otherwise.
//!
//! The crate's bindings were generated for Embree 3.12.1. Debian's 3.13.5
//! header keeps the same layouts for everything used here
//! (`RTC_MAX_INSTANCE_LEVEL_COUNT` 1, the `RTCRay`/`RTCHit` fields);
//! [`version`] is checked before use.
#![allow(unsafe_code)] // FFI

use super::mesh::Mesh;
use super::raygen::BenchRay;
use super::{BuildStats, Hit, Tracer};
use anyhow::{bail, Result};
use embree::sys::*;
use std::ffi::CString;
use std::os::raw::c_void;
use std::sync::atomic::{AtomicIsize, Ordering};
use std::time::Instant;

/// Embree's `RTC_INVALID_GEOMETRY_ID` (not in the crate's bindings).
const INVALID_ID: u32 = u32::MAX;

/// Bytes Embree reports as allocated by all devices, and their high-water mark.
static LIVE: AtomicIsize = AtomicIsize::new(0);
static PEAK: AtomicIsize = AtomicIsize::new(0);

/// Embree calls this with `bytes > 0` before it allocates and `bytes < 0`
/// after it frees; returning true lets the allocation go ahead.
unsafe extern "C" fn memory_monitor(_user: *mut c_void, bytes: isize, _post: bool) -> bool {
    let now = LIVE.fetch_add(bytes, Ordering::Relaxed) + bytes;
    PEAK.fetch_max(now, Ordering::Relaxed);
    true
}

/// An Embree device and a committed scene.
#[derive(Debug)]
pub struct EmbreeTracer {
    device: RTCDevice,
    scene: RTCScene,
}

// SAFETY: a committed Embree scene may be traced from any number of
// threads at once (rtcIntersect1 and rtcOccluded1 are thread-safe on a
// committed scene, per Embree's API documentation); the handles are only
// released in `drop`.
unsafe impl Send for EmbreeTracer {}
// SAFETY: see above.
unsafe impl Sync for EmbreeTracer {}

impl Drop for EmbreeTracer {
    fn drop(&mut self) {
        // SAFETY: both handles are valid and owned by this value.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

fn new_device(threads: Option<usize>) -> Result<RTCDevice> {
    // YUBIN_EMBREE_VERBOSE=2 makes Embree print its BVH statistics;
    // YUBIN_EMBREE_ISA=avx2 (or sse4.2, ...) limits its instruction set.
    let verbose = std::env::var("YUBIN_EMBREE_VERBOSE")
        .map_or(String::new(), |v| format!("verbose={v},"))
        + &std::env::var("YUBIN_EMBREE_ISA").map_or(String::new(), |v| format!("isa={v},"));
    let config =
        CString::new(verbose + &threads.map_or(String::new(), |t| format!("threads={t}")))?;
    // SAFETY: a valid NUL-terminated config string.
    let device = unsafe { rtcNewDevice(config.as_ptr()) };
    if device.is_null() {
        bail!("rtcNewDevice failed (is libembree3 installed? run crates/yubin-bench/setup.sh)");
    }
    // SAFETY: a valid device and a callback with the documented signature.
    unsafe {
        rtcSetDeviceMemoryMonitorFunction(device, Some(memory_monitor), std::ptr::null_mut())
    };
    Ok(device)
}

fn check(device: RTCDevice, what: &str) -> Result<()> {
    // SAFETY: a valid device.
    let e = unsafe { rtcGetDeviceError(device) };
    if e != RTCError::NONE {
        bail!("Embree error after {what}: {e:?}");
    }
    Ok(())
}

/// The library's version and what it dispatches to, checked against the
/// layouts this code was written for.
pub fn version() -> Result<String> {
    let device = new_device(None)?;
    // SAFETY: a valid device; property queries have no preconditions.
    let (v, r4, r8, r16, tasking) = unsafe {
        (
            rtcGetDeviceProperty(device, RTCDeviceProperty::VERSION),
            rtcGetDeviceProperty(device, RTCDeviceProperty::NATIVE_RAY4_SUPPORTED),
            rtcGetDeviceProperty(device, RTCDeviceProperty::NATIVE_RAY8_SUPPORTED),
            rtcGetDeviceProperty(device, RTCDeviceProperty::NATIVE_RAY16_SUPPORTED),
            rtcGetDeviceProperty(device, RTCDeviceProperty::TASKING_SYSTEM),
        )
    };
    // SAFETY: releasing the device created above.
    unsafe { rtcReleaseDevice(device) };
    let (major, minor, patch) = (v / 10000, v / 100 % 100, v % 100);
    if major != 3 || minor < 12 {
        bail!("Embree {major}.{minor}.{patch} found; the embree 0.3.8 bindings need Embree 3.12 or later 3.x");
    }
    let tasking = ["internal", "TBB", "PPL"]
        .get(tasking as usize)
        .unwrap_or(&"?");
    Ok(format!(
        "Embree {major}.{minor}.{patch}, native ray4/8/16 {r4}/{r8}/{r16}, tasking {tasking}"
    ))
}

/// One build: returns the tracer, the commit time, and the bytes the
/// commit retained and peaked at.
fn build_once(mesh: &Mesh, threads: Option<usize>) -> Result<(EmbreeTracer, f64, isize, isize)> {
    let device = new_device(threads)?;
    // SAFETY: every handle comes from the calls before it on a valid
    // device; the buffers Embree returns have room for the requested
    // element counts of 12-byte elements, which the copies fill exactly.
    unsafe {
        let geometry = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
        let vertices = rtcSetNewGeometryBuffer(
            geometry,
            RTCBufferType::VERTEX,
            0,
            RTCFormat::FLOAT3,
            12,
            mesh.positions.len(),
        ) as *mut [f32; 3];
        let indices = rtcSetNewGeometryBuffer(
            geometry,
            RTCBufferType::INDEX,
            0,
            RTCFormat::UINT3,
            12,
            mesh.indices.len(),
        ) as *mut [u32; 3];
        if vertices.is_null() || indices.is_null() {
            check(device, "rtcSetNewGeometryBuffer")?;
            bail!("Embree returned no geometry buffer");
        }
        std::ptr::copy_nonoverlapping(mesh.positions.as_ptr(), vertices, mesh.positions.len());
        std::ptr::copy_nonoverlapping(mesh.indices.as_ptr(), indices, mesh.indices.len());
        rtcSetGeometryBuildQuality(geometry, RTCBuildQuality::MEDIUM);
        rtcCommitGeometry(geometry);
        let scene = rtcNewScene(device);
        rtcSetSceneBuildQuality(scene, RTCBuildQuality::MEDIUM);
        rtcAttachGeometry(scene, geometry);
        rtcReleaseGeometry(geometry);
        let tracer = EmbreeTracer { device, scene };
        check(device, "geometry set-up")?;

        let before = LIVE.load(Ordering::SeqCst);
        PEAK.store(before, Ordering::SeqCst);
        let t0 = Instant::now();
        rtcCommitScene(scene);
        let dt = t0.elapsed().as_secs_f64();
        check(device, "rtcCommitScene")?;
        let retained = LIVE.load(Ordering::SeqCst) - before;
        let peak = PEAK.load(Ordering::SeqCst) - before;
        Ok((tracer, dt, retained, peak))
    }
}

/// Builds `reps` times with 1 and with all threads, each after one
/// untimed warm-up build (see [`BuildStats::warm_up`]); keeps the last
/// all-threads scene for tracing.
pub fn build(mesh: &Mesh, reps: usize) -> Result<(EmbreeTracer, BuildStats)> {
    let mut stats = BuildStats::default();
    let (_, warm_up, _, _) = build_once(mesh, Some(1))?;
    stats.warm_up = Some(std::time::Duration::from_secs_f64(warm_up));
    for _ in 0..reps {
        let (_, dt, _, _) = build_once(mesh, Some(1))?;
        stats.build_1t.push(std::time::Duration::from_secs_f64(dt));
    }
    build_once(mesh, None)?;
    let mut kept = None;
    for _ in 0..reps {
        let (tracer, dt, retained, peak) = build_once(mesh, None)?;
        stats.build_2t.push(std::time::Duration::from_secs_f64(dt));
        stats.accel_bytes = Some(retained.max(0) as usize);
        stats.peak_build_bytes = Some(peak.max(0) as usize);
        kept = Some(tracer);
    }
    stats.note = "rtcCommitScene, quality MEDIUM; bytes from the device memory monitor".into();
    Ok((kept.expect("reps > 0"), stats))
}

#[inline(always)]
fn context(coherent: bool) -> RTCIntersectContext {
    RTCIntersectContext {
        flags: if coherent {
            RTCIntersectContextFlags::COHERENT
        } else {
            RTCIntersectContextFlags::INCOHERENT
        },
        filter: None,
        instID: [INVALID_ID; 1],
    }
}

#[inline(always)]
fn rtc_ray(r: &BenchRay) -> RTCRay {
    RTCRay {
        org_x: r.o[0],
        org_y: r.o[1],
        org_z: r.o[2],
        tnear: 0.0,
        dir_x: r.d[0],
        dir_y: r.d[1],
        dir_z: r.d[2],
        time: 0.0,
        tfar: f32::INFINITY,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl Tracer for EmbreeTracer {
    fn closest(&self, rays: &[BenchRay], out: &mut [Hit], coherent: bool) {
        let mut ctx = context(coherent);
        for (r, o) in rays.iter().zip(out) {
            let mut rayhit = RTCRayHit {
                ray: rtc_ray(r),
                hit: RTCHit {
                    Ng_x: 0.0,
                    Ng_y: 0.0,
                    Ng_z: 0.0,
                    u: 0.0,
                    v: 0.0,
                    primID: INVALID_ID,
                    geomID: INVALID_ID,
                    instID: [INVALID_ID; 1],
                },
            };
            // SAFETY: a committed scene, and a context and ray-hit owned by
            // this frame with the layouts of Embree 3's header.
            unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rayhit) };
            *o = if rayhit.hit.geomID != INVALID_ID {
                Hit {
                    t: rayhit.ray.tfar,
                    prim: rayhit.hit.primID,
                }
            } else {
                Hit::MISS
            };
        }
    }

    fn occluded(&self, rays: &[BenchRay], out: &mut [bool], coherent: bool) {
        let mut ctx = context(coherent);
        for (r, o) in rays.iter().zip(out) {
            let mut ray = rtc_ray(r);
            // SAFETY: as in `closest`.
            unsafe { rtcOccluded1(self.scene, &mut ctx, &mut ray) };
            // Embree sets tfar to -inf when the ray is occluded.
            *o = ray.tfar < 0.0;
        }
    }
}
