"""Denoises a shatter EXR frame with Intel's Open Image Denoise (pyoidn), guided by the frame's
Denoising Albedo and Denoising Normal passes, and writes the frame again with the denoised
colour: every other channel and the header as they were.

Run by scripts/denoise.sh; usage: python denoise.py FRAME.exr OUT.exr
"""

import sys

import numpy as np
import OpenEXR
import pyoidn

ALBEDO = "ViewLayer.Denoising Albedo"
NORMAL = "ViewLayer.Denoising Normal"


def stack(channels, names):
    """The named channels as one float32 image of shape (height, width, len(names))."""
    return np.stack([channels[name].pixels.astype(np.float32) for name in names], axis=-1)


def main(source, target):
    with OpenEXR.File(source, separate_channels=True) as frame:
        header = dict(frame.header())
        channels = dict(frame.channels())
    missing = [n for n in (f"{ALBEDO}.R", f"{NORMAL}.X") if n not in channels]
    if missing:
        sys.exit(f"{source}: no denoising passes ({', '.join(missing)}): render with render.denoising_passes = true")
    color = stack(channels, ["R", "G", "B"])
    albedo = np.clip(stack(channels, [f"{ALBEDO}.{c}" for c in "RGB"]), 0.0, 1.0)
    normal = stack(channels, [f"{NORMAL}.{c}" for c in "XYZ"])
    denoised = pyoidn.denoise(color, albedo, normal, hdr=True)
    for k, name in enumerate("RGB"):
        channels[name] = OpenEXR.Channel(denoised[..., k].astype(channels[name].pixels.dtype))
    OpenEXR.File(header, channels).write(target)
    print(f"{target}: denoised by Open Image Denoise (pyoidn)")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: denoise.py FRAME.exr OUT.exr")
    main(sys.argv[1], sys.argv[2])
