#!/usr/bin/env python3
"""Writes crates/yubin-core/src/light/sunsky_tables.bin: the Hosek–Wilkie data yubin's `sunsky`
reads, taken from the data files of the `mitsuba` wheel (mitsuba/data/sunsky/, whose LICENSE says
they are issued from the Hosek–Wilkie sky model, BSD-3, (c) 2012-2013 Lukas Hosek and Alexander
Wilkie). Run with scripts/mitsuba-ref python scripts/sunsky-tables.py.

The output is little-endian float32 arrays, back to back, in this order and shape:
  sky_params_rgb  [10 turbidity][2 albedo][6 control points][3 channels][9 parameters]
  sky_rad_rgb     [10][2][6][3]
  sun_irradiance  [10 turbidity][30 elevations 2, 5, ..., 89 degrees][11 wavelengths 320..720 nm]
  sun_rad_spec    [10 turbidity][45 segments][11 wavelengths][4 polynomial coefficients]
  sun_ld_spec     [11 wavelengths][6 limb-darkening coefficients]
"""
import os
import struct
import sys

import mitsuba
import numpy as np


def read_tensor_file(path):
    data = open(path, 'rb').read()
    assert data[:12] == b'tensor_file\0', path
    (count,) = struct.unpack_from('<I', data, 14)
    at, fields = 18, {}
    types = {10: np.float32, 11: np.float64}
    for _ in range(count):
        (n,) = struct.unpack_from('<H', data, at); at += 2
        name = data[at:at + n].decode(); at += n
        (ndim, dtype, offset) = struct.unpack_from('<HBQ', data, at); at += 11
        shape = struct.unpack_from('<%dQ' % ndim, data, at); at += 8 * ndim
        t = np.dtype(types[dtype])
        size = int(np.prod(shape)) * t.itemsize
        fields[name] = np.frombuffer(data[offset:offset + size], dtype=t).reshape(shape)
    return fields


root = os.path.join(os.path.dirname(mitsuba.__file__), 'data', 'sunsky')
datasets = read_tensor_file(os.path.join(root, 'sunsky_datasets.bin'))
sampling = read_tensor_file(os.path.join(root, 'sampling_data.bin'))
arrays = [
    (datasets['sky_params_rgb'], (10, 2, 6, 3, 9)),
    (datasets['sky_rad_rgb'], (10, 2, 6, 3)),
    (sampling['sun_irradiance'], (10, 30, 11)),
    (datasets['sun_rad_spec'], (10, 45, 11, 4)),
    (datasets['sun_ld_spec'], (11, 6)),
]
out = sys.argv[1] if len(sys.argv) > 1 else 'crates/yubin-core/src/light/sunsky_tables.bin'
with open(out, 'wb') as f:
    for a, shape in arrays:
        assert a.shape == shape, (a.shape, shape)
        f.write(np.ascontiguousarray(a, dtype='<f4').tobytes())
print(out, os.path.getsize(out), 'bytes')
