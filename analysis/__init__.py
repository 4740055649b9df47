"""rodpack analysis: observables of granular packings, identical for every engine.

Read a run with :class:`analysis.io.RunData`; observables are compute objects
(:mod:`analysis.base`: configure, ``compute()`` on a frame or ``run()`` over frames,
read results) or pure functions on plain arrays:

* :mod:`analysis.packing`  packing fraction: global, slabs, layers, filled part
* :mod:`analysis.contacts` contacts from tables or geometry, contact numbers, rattlers,
  contact types, 2-D bond counting, glued-sphere rods
* :mod:`analysis.order`    2-D ``S_n``, 3-D ``Q`` tensor, gravity order, angle
  histograms, ``Q(r)``
* :mod:`analysis.stress`   particle, box, slab and element stress, principal axes, walls
* :mod:`analysis.janssen`  Janssen fits; :mod:`analysis.jamming` the jamming point
* :mod:`analysis.theory`   closed-form references; :mod:`analysis.caging` caging numbers;
  :mod:`analysis.cages` caged particles of a frame
* :mod:`analysis.growth`   growth curves: the jump of ``<C>(phi)``, rate independence
* :mod:`analysis.geometry` spherocylinder geometry; :mod:`analysis.walls` wall contacts

See docs/analysis.md for the equations and figures.
"""
from analysis.frame import Contacts, Frame

__all__ = ["Contacts", "Frame"]
