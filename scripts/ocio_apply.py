"""OpenColorIO's CPU processor on raw pixels, for yubin's OCIO tests.

    python ocio_apply.py CONFIG DISPLAY VIEW LOOKS IN.f32 OUT.u8 WIDTH HEIGHT

IN.f32 holds WIDTH x HEIGHT RGB float32 pixels (little-endian, rows top
first) in the config's scene_linear space; OUT.u8 receives the display
values as 8-bit RGB, each channel clamped to [0, 1] and rounded. LOOKS is
OpenColorIO's look string ("" for none; "High Contrast", "+A, -B").
The looks override the view's own, as OpenColorIO's legacy viewing
pipeline (and Blender's look menu) applies them.
"""

import sys

import numpy as np
import PyOpenColorIO as ocio


def main():
    config_path, display, view, looks, src, dst, width, height = sys.argv[1:9]
    config = ocio.Config.CreateFromFile(config_path)
    dvt = ocio.DisplayViewTransform(
        src=ocio.ROLE_SCENE_LINEAR, display=display, view=view
    )
    pipeline = ocio.LegacyViewingPipeline()
    pipeline.setDisplayViewTransform(dvt)
    pipeline.setLooksOverrideEnabled(bool(looks))
    pipeline.setLooksOverride(looks)
    cpu = pipeline.getProcessor(config).getDefaultCPUProcessor()
    pixels = np.fromfile(src, dtype="<f4").astype(np.float32)
    assert pixels.size == int(width) * int(height) * 3, "size mismatch"
    cpu.applyRGB(pixels)
    out = np.round(np.clip(pixels, 0.0, 1.0) * 255.0).astype(np.uint8)
    out.tofile(dst)


if __name__ == "__main__":
    main()
