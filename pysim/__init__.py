"""pysim: the rodpack reference discrete-element engine (Numba).

Spheres are spherocylinders with spine length ``L = 0``. See ``docs/architecture.md``
for where everything lives and ``shared/science.md`` for the physics.
"""
from pysim.state import State, sphere_mass

__all__ = ["State", "sphere_mass"]
__version__ = "0.1.0"
