"""Hard spheres in a periodic cube: the packing protocols of Baranau & Tallarek (2014,
shared/papers/baranau-tallarek-2014_rcp-limits-hard-spheres.txt).

* :mod:`pysim.hard.collide` - when two spheres with growing diameters touch, and the
  collision rule;
* :mod:`pysim.hard.heap` - the event queue (an indexed binary heap);
* :mod:`pysim.hard.cells` - cell grids, to find neighbours;
* :mod:`pysim.hard.edmd` - event-driven molecular dynamics (:class:`~pysim.hard.edmd.EDMD`)
  with neighbour lists: blocks of collisions, reduced pressure, velocity rescaling;
* :mod:`pysim.hard.ls` - the Lubachevsky-Stillinger compression;
* :mod:`pysim.hard.mls` - the modified LS search for the closest jammed configuration;
* :mod:`pysim.hard.fb` - the force-biased algorithm;
* :mod:`pysim.hard.start` - the Poisson start and the box.

Units (the paper's, Sec. III.B): every mass 1, Boltzmann's constant 1, lengths in units
of the mean nominal diameter; the diameters are ``D_i(t) = r(t) D_i^nom``.
"""
