"""Packing fraction."""
from __future__ import annotations

import numpy as np

from analysis.frame import Frame


def packing_fraction(frame: Frame) -> float:
    """Global packing fraction ``phi = sum_i V_i / V_box`` (spherocylinder volumes)."""
    return float(np.sum(frame.particle_volumes()) / frame.volume)
