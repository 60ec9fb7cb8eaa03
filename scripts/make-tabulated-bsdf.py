#!/usr/bin/env python3
"""Write a small, valid RGL-style `.bsdf` tensor file (Dupuy & Jakob 2018,
"An Adaptive Parameterization for Efficient Material Acquisition and
Rendering") that tabulates an isotropic GGX conductor-like reflectance with an
RGB tint.  numpy only; written from the format/algorithm notes in notes.md.

Usage:
    python3 make_tabulated_ggx.py [out.bsdf] [--alpha 0.3] [--tint r,g,b]
                                  [--phi-i-size 1|2] [--n-theta-i 8]
                                  [--vndf-res 32] [--sample-res 24]

Quantity stored (jacobian = 1):
    rgb(sample) = f_r(wi, wo) cos(theta_o) / p_vndf(wo),
    p_vndf(wo)  = D(wm) / (4 sigma(wi))
so for GGX with Smith height-correlated G2 and constant "Fresnel" tint:
    rgb(sample) = tint * G2(wi, wo) / G1(wi).
A renderer reconstructs f_r cos = rgb(sample) * D(wm) / (4 sigma(wi)).
"""
import argparse
import struct

import numpy as np

PI = np.pi

# --------------------------------------------------------------------------
# Tensor file I/O  ("tensor_file\0", version 1.0, little endian)
# --------------------------------------------------------------------------
DTYPE_CODE = {np.dtype(np.uint8): 1, np.dtype(np.int8): 2,
              np.dtype(np.uint16): 3, np.dtype(np.int16): 4,
              np.dtype(np.uint32): 5, np.dtype(np.int32): 6,
              np.dtype(np.uint64): 7, np.dtype(np.int64): 8,
              np.dtype(np.float16): 9, np.dtype(np.float32): 10,
              np.dtype(np.float64): 11}
CODE_DTYPE = {v: k for k, v in DTYPE_CODE.items()}


def write_tensor_file(path, fields, align=8):
    """fields: ordered dict name -> numpy array (or str -> uint8 bytes)."""
    arrs = []
    for name, v in fields.items():
        if isinstance(v, str):
            v = np.frombuffer(v.encode('utf8'), dtype=np.uint8)
        v = np.ascontiguousarray(v)
        if v.dtype not in DTYPE_CODE:
            raise ValueError('unsupported dtype %s' % v.dtype)
        arrs.append((name.encode('utf8'), v))
    # header size
    pos = 12 + 2 + 4
    for name, v in arrs:
        pos += 2 + len(name) + 2 + 1 + 8 + 8 * v.ndim
    offsets = []
    for name, v in arrs:
        pos = (pos + align - 1) // align * align
        offsets.append(pos)
        pos += v.nbytes
    out = bytearray()
    out += b'tensor_file\0'
    out += struct.pack('<BB', 1, 0)
    out += struct.pack('<I', len(arrs))
    for (name, v), off in zip(arrs, offsets):
        out += struct.pack('<H', len(name)) + name
        out += struct.pack('<H', v.ndim)
        out += struct.pack('<B', DTYPE_CODE[v.dtype])
        out += struct.pack('<Q', off)
        out += struct.pack('<' + 'Q' * v.ndim, *v.shape)
    for (name, v), off in zip(arrs, offsets):
        out += b'\0' * (off - len(out))
        out += v.astype(v.dtype.newbyteorder('<'), copy=False).tobytes()
    with open(path, 'wb') as f:
        f.write(out)
    return len(out)


def read_tensor_file(path):
    data = open(path, 'rb').read()
    if data[:12] != b'tensor_file\0':
        raise ValueError('bad magic')
    ver = struct.unpack_from('<BB', data, 12)
    n, = struct.unpack_from('<I', data, 14)
    p = 18
    res = {}
    for _ in range(n):
        ln, = struct.unpack_from('<H', data, p); p += 2
        name = data[p:p + ln].decode('utf8'); p += ln
        ndim, = struct.unpack_from('<H', data, p); p += 2
        code, = struct.unpack_from('<B', data, p); p += 1
        off, = struct.unpack_from('<Q', data, p); p += 8
        shape = struct.unpack_from('<' + 'Q' * ndim, data, p); p += 8 * ndim
        dt = CODE_DTYPE[code].newbyteorder('<')
        cnt = int(np.prod(shape)) if ndim else 1
        res[name] = np.frombuffer(data, dtype=dt, count=cnt,
                                  offset=off).reshape(shape)
    return res, ver


# --------------------------------------------------------------------------
# Square <-> spherical mapping of the paper (u.x <-> theta, u.y <-> phi)
# --------------------------------------------------------------------------
def u2theta(u):
    return u * u * (PI / 2)


def u2phi(u):
    return (2 * u - 1) * PI


def theta2u(t):
    return np.sqrt(t * (2 / PI))


def phi2u(p):
    return (p + PI) / (2 * PI)


# --------------------------------------------------------------------------
# Continuous marginal/conditional warp of a bilinear density on [0,1]^2
# (single slice, no parameters).  Same math as described in notes.md.
# --------------------------------------------------------------------------
class ContinuousWarp2D:
    def __init__(self, data, normalize=True):
        d = np.asarray(data, dtype=np.float64)
        self.h, self.w = d.shape
        sx, sy = 0.5 / (self.w - 1), 0.5 / (self.h - 1)
        cond = np.cumsum(sx * (d[:, :-1] + d[:, 1:]), axis=1)     # [h, w-1]
        rows = cond[:, -1]
        marg = np.cumsum(sy * (rows[:-1] + rows[1:]))             # [h-1]
        norm = 1.0 / marg[-1] if normalize else 1.0
        self.data, self.cond, self.marg = d * norm, cond * norm, marg * norm

    @staticmethod
    def _segment(s, inv_width, v0, v1):
        non_const = abs(v0 - v1) > 1e-4 * (v0 + v1)
        s = s * 2 * inv_width
        if non_const:
            s = v0 - np.sqrt(max(v0 * v0 + s * (v1 - v0), 0.0))
            div = v0 - v1
        else:
            div = v0 + v1
        return s / div if div != 0 else s

    def sample(self, u):
        eps = 2.0 ** -24
        ux, uy = np.clip(u, eps, 1 - eps)
        w, h = self.w, self.h
        # row (y) from the marginal
        row = int(min(np.searchsorted(self.marg, uy, side='left'), h - 2))
        uy -= self.marg[row - 1] if row > 0 else 0.0
        r0, r1 = self.cond[row, -1], self.cond[row + 1, -1]
        ty = self._segment(uy, h - 1, r0, r1)
        ux *= (1 - ty) * r0 + ty * r1
        ci = (1 - ty) * self.cond[row] + ty * self.cond[row + 1]
        col = int(min(np.searchsorted(ci, ux, side='left'), w - 2))
        ux -= ci[col - 1] if col > 0 else 0.0
        d = self.data
        c0 = (1 - ty) * d[row, col] + ty * d[row + 1, col]
        c1 = (1 - ty) * d[row, col + 1] + ty * d[row + 1, col + 1]
        tx = self._segment(ux, w - 1, c0, c1)
        return (np.array([(col + tx) / (w - 1), (row + ty) / (h - 1)]),
                (1 - tx) * c0 + tx * c1)


# --------------------------------------------------------------------------
# GGX (Trowbridge-Reitz) helpers; alpha = (alpha_x, alpha_y)
# --------------------------------------------------------------------------
def ggx_D(m, ax, ay):
    """m: array [3, ...] of unit vectors."""
    x, y, z = m
    t = (x / ax) ** 2 + (y / ay) ** 2 + z ** 2
    return np.where(z > 0, 1.0 / (PI * ax * ay * t * t), 0.0)


def ggx_lambda(w, ax, ay):
    x, y, z = w
    z2 = np.maximum(z * z, 1e-30)
    a2t2 = ((ax * x) ** 2 + (ay * y) ** 2) / z2
    return 0.5 * (-1 + np.sqrt(1 + a2t2))


def ggx_sigma(w, ax, ay):
    """Projected area sigma(w) = int D(m) <w,m>+ dm = cos (1 + Lambda)."""
    x, y, z = w
    z = np.maximum(z, 0.0)
    return 0.5 * (z + np.sqrt(z * z + (ax * x) ** 2 + (ay * y) ** 2))


def sph(theta, phi):
    return np.array([np.sin(theta) * np.cos(phi),
                     np.sin(theta) * np.sin(phi),
                     np.cos(theta) + 0 * phi])


def build(alpha=0.3, alpha_y=None, tint=(0.9, 0.6, 0.3), n_theta_i=8,
          vndf_res=32, sample_res=24, ndf_res=32, sigma_res=16,
          phi_i_size=1, phi_i=None):
    """phi_i=None -> isotropic file (phi_i = [0] or [-pi, pi] with identical
    slices, per phi_i_size).  phi_i=array -> anisotropic file whose tables
    use absolute azimuths (phi_i range decides Mitsuba's 'reduction')."""
    ax = alpha
    ay = alpha if alpha_y is None else alpha_y
    tint = np.asarray(tint, dtype=np.float64)
    lum_w = np.array([0.2126, 0.7152, 0.0722])
    theta_i = u2theta(np.linspace(0, 1, n_theta_i))
    isotropic = phi_i is None
    if isotropic:
        phi_i = np.array([0.0]) if phi_i_size == 1 else np.array([-PI, PI])
    phi_i = np.asarray(phi_i, dtype=np.float64)

    # NDF table: ndf[j, i] = D at (u.x = i/(n-1) -> theta, u.y = j/(n-1) -> phi)
    g = np.linspace(0, 1, ndf_res)
    ndf = ggx_D(sph(u2theta(g)[None, :], u2phi(g)[:, None]), ax, ay)
    # sigma table over (u.x -> theta_i, u.y -> phi_i)
    g = np.linspace(0, 1, sigma_res)
    sigma = ggx_sigma(sph(u2theta(g)[None, :], u2phi(g)[:, None]), ax, ay)

    vndf = np.zeros((len(phi_i), n_theta_i, vndf_res, vndf_res))
    rgb = np.zeros((len(phi_i), n_theta_i, 3, sample_res, sample_res))
    lum = np.zeros((len(phi_i), n_theta_i, sample_res, sample_res))

    uv = np.linspace(0, 1, vndf_res)
    th_m = u2theta(uv)[None, :]          # along x (columns)
    jac = 2 * PI ** 2 * uv[None, :] * np.sin(th_m)   # |d omega_m / d u|

    for p, pi_ in enumerate(phi_i):
        for k, ti in enumerate(theta_i):
            # isotropic: slice is relative to phi_i -> tabulate at phi_i = 0
            phi_w = 0.0 if isotropic else pi_
            wi = sph(ti, phi_w)
            ph_m = u2phi(uv)[:, None] + (phi_w if isotropic else 0.0)
            m = sph(th_m, ph_m)
            dot_im = np.maximum(0.0, np.tensordot(wi, m, axes=1))
            slice_v = ggx_D(m, ax, ay) * dot_im / ggx_sigma(wi, ax, ay) * jac
            warp = ContinuousWarp2D(slice_v)
            lam_i = ggx_lambda(wi, ax, ay)
            s_rgb = np.zeros((3, sample_res, sample_res))
            for j in range(sample_res):
                for i in range(sample_res):
                    s = np.array([i, j]) / (sample_res - 1.0)
                    u_m, _ = warp.sample(s)
                    mm = sph(u2theta(u_m[0]), u2phi(u_m[1]) +
                             (phi_w if isotropic else 0.0))
                    wo = 2 * np.dot(wi, mm) * mm - wi
                    if wo[2] <= 0 or np.dot(wi, mm) <= 0:
                        continue
                    g2_over_g1 = (1 + lam_i) / (1 + lam_i +
                                                ggx_lambda(wo, ax, ay))
                    s_rgb[:, j, i] = tint * g2_over_g1
            vndf[p, k] = slice_v
            rgb[p, k] = s_rgb
            lum[p, k] = np.tensordot(lum_w, s_rgb, axes=1)

    desc = ('Tabulated GGX, alpha=(%g, %g), tint=(%g, %g, %g), %s; '
            'synthetic test file for yubin measured BSDF' %
            (ax, ay, *tint, 'isotropic' if isotropic else 'anisotropic'))
    f32 = np.float32
    fields = {
        'description': desc,
        'jacobian': np.array([1], dtype=np.uint8),
        'theta_i': theta_i.astype(f32),
        'phi_i': phi_i.astype(f32),
        'ndf': ndf.astype(f32),
        'sigma': sigma.astype(f32),
        'vndf': vndf.astype(f32),
        'luminance': lum.astype(f32),
        'rgb': rgb.astype(f32),
    }
    return fields


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('out', nargs='?', default='ggx_a0.3_iso.bsdf')
    ap.add_argument('--alpha', type=float, default=0.3)
    ap.add_argument('--alpha-y', type=float, default=None,
                    help='anisotropic roughness along y (needs --aniso)')
    ap.add_argument('--tint', default='0.9,0.6,0.3')
    ap.add_argument('--phi-i-size', type=int, default=1, choices=[1, 2],
                    help='isotropic files: phi_i = [0] or [-pi, pi]')
    ap.add_argument('--aniso', type=int, default=0, metavar='N',
                    help='write an anisotropic file with N phi_i values')
    ap.add_argument('--reduction', type=int, default=1, choices=[1, 2, 4],
                    help='anisotropic phi_i range: 2pi / reduction, '
                         'starting at -pi')
    ap.add_argument('--n-theta-i', type=int, default=8)
    ap.add_argument('--vndf-res', type=int, default=32)
    ap.add_argument('--sample-res', type=int, default=24)
    a = ap.parse_args()
    phi_i = None
    if a.aniso:
        phi_i = np.linspace(-PI, -PI + 2 * PI / a.reduction, a.aniso)
    fields = build(alpha=a.alpha, alpha_y=a.alpha_y,
                   tint=[float(x) for x in a.tint.split(',')],
                   n_theta_i=a.n_theta_i, vndf_res=a.vndf_res,
                   sample_res=a.sample_res, phi_i_size=a.phi_i_size,
                   phi_i=phi_i)
    n = write_tensor_file(a.out, fields)
    print('wrote %s (%d bytes)' % (a.out, n))
    for k, v in fields.items():
        if not isinstance(v, str):
            print('  %-12s %-8s %s' % (k, v.dtype, v.shape))


if __name__ == '__main__':
    main()
