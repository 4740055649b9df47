"""The contact loop: forces, torques, virial and the contact table from the pairs.

One concept per module:

* :mod:`~pysim.contacts.kinematics`: the pair's geometry as scalars, the minimum image
  (:func:`min_image`), the contact points of two spines (:func:`spine_gap`; 2-D rods
  also :func:`end_bond`), and the normal, overlap and relative velocity at the contact
  (:func:`~pysim.contacts.kinematics.contact_motion`).
* :mod:`~pysim.contacts.law`: the contact law, written once
  (:func:`~pysim.contacts.law.contact_law`: normal part, tangential part with the
  spring, cohesion), inlined into every pass, their SIMD lanes and the walls
  (:mod:`pysim.walls`); :func:`pair_force`, the law at a pair's closest points.
* :mod:`~pysim.contacts.pair`: the general loops, one pair at a time, for any shape and
  law: :func:`pair_pass` (every step) and :func:`pair_forces` (serial, records the
  contact table).
* :mod:`~pysim.contacts.spheres`, :mod:`~pysim.contacts.rods`: :func:`sphere_pass` and
  :func:`rod_pass`, the same sums as ``pair_pass`` in the same order, with the laws of a
  chunk of pairs on SIMD lanes.
* :mod:`~pysim.contacts.reactions`: the reactions on the pairs' second particles, stored
  per pair or added at once, and :func:`reduce_pass`, which completes the forces.
* :mod:`~pysim.contacts.partition`: blocks of rows, the threads' parts and the particles
  they share (:func:`part_bounds`, :func:`own_flags`, :func:`clear_slots`).
* :mod:`~pysim.contacts.stats`: the block sums (energy, contacts, virial) and the largest
  overlap (:func:`block_totals`, :func:`block_worst`, :func:`worst_overlap`).

The scalar functions take and return scalars only, so that the hot loops pass no arrays
to them (an array argument costs atomic reference-count updates per call). Two loops call
them:

* :func:`pair_pass` + :func:`reduce_pass`, the force evaluation of every step, on any
  number of threads. ``pair_pass`` walks the rows of the pair list (particle ``i``
  owns its pairs ``(i, j > i)`` and their tangential springs ``hist``), sums the forces
  and torques on ``i`` in row order and stores the reaction on ``j`` per pair (``fj``,
  at the pair's place in the transposed list, so that the reactions on ``j`` lie
  together in pair order); ``reduce_pass`` then adds to each particle ``p`` the
  reactions of the pairs in which it is the second member, summed from zero in pair
  order, to the row sum. On one
  thread (``scatter``) the rows run in order and the pass adds each reaction to the
  second particle at once: when row ``i`` is reached the reactions on ``i`` are
  complete, and ``f_i = row sum + reaction sum`` is the same sum in the same order, with
  no per-pair store and gather. Global sums (elastic energy, contacts, virial) are taken
  per fixed block of rows and the block sums added in block order. Nothing depends on
  how rows are shared among threads, so 1 and 2 threads give the same bits. Listed rod
  pairs that the motion since the list build keeps out of reach are skipped
  (:func:`pysim.neighbors.motion_bound`; they would add nothing).
  :func:`sphere_pass` replaces ``pair_pass`` when every particle is a sphere: the same
  sums in the same order, with the contact laws of a chunk of pairs evaluated together
  on SIMD lanes (gather, laws, scatter). :func:`rod_pass` replaces it for rods with one
  bond per pair: the closest points and the laws of a chunk on SIMD lanes, the same
  bits (``end_bonds`` rods keep ``pair_pass``). These two scatter on threads as well:
  each thread takes a contiguous part of the rows and adds the reactions at once, except
  on the few particles that also receive reactions from an earlier part, whose
  reactions are stored per pair and summed in pair order afterwards (the same sum).
* :func:`pair_forces`, a plain serial loop in pair order that can also record the
  contact table (used with each dump, and by the tests).

Pairs out of contact add nothing and every pair's contribution is a pure function of
its two particles, so forces do not depend on how many extra pairs the Verlet list
holds: results are bit-identical across list rebuilds and restarts.

With ``spine_contact = "end_bonds"`` (:func:`end_bond`) a rod pair is
up to four bonds, each a contact of the same law (``"end_bonds_distinct"``: a bond that
repeats another's two points, :func:`repeats_bond`, counts once); a pair's forces,
torques and virial are the sums over its bonds, and its recorded contact has the summed
force, the force-weighted mean point, and the normal and overlap of the deepest bond.

Geometry (science.md section 2): closest points ``p_i = x_i + s u_i`` and
``p_j = x_j + t u_j`` of the spines (:func:`pysim.geometry.closest_params`), distance
``d = |p_j - p_i|``, overlap ``delta = R_i + R_j - d``, normal ``n = (p_j - p_i)/d``,
contact point in the middle of the overlap ``c = p_i + (R_i - delta/2) n``.

The names other modules use are re-exported here (``from pysim.contacts import ...``).
"""
from __future__ import annotations

from pysim.contacts.kinematics import end_bond, min_image, repeats_bond, spine_gap
from pysim.contacts.law import pair_force
from pysim.contacts.pair import REC_COLUMNS, pair_forces, pair_pass
from pysim.contacts.partition import BLOCK, clear_slots, own_flags, part_bounds
from pysim.contacts.reactions import FJ_COLUMNS, PAIR_SCRATCH, SEP, reduce_pass
from pysim.contacts.rods import RCAP, rod_pass
from pysim.contacts.spheres import CAP, PAD, sphere_pass
from pysim.contacts.stats import block_totals, block_worst, worst_overlap

__all__ = ["BLOCK", "CAP", "FJ_COLUMNS", "PAD", "PAIR_SCRATCH", "RCAP", "REC_COLUMNS", "SEP",
           "block_totals", "block_worst", "clear_slots", "end_bond", "min_image",
           "own_flags", "pair_force", "pair_forces", "pair_pass", "part_bounds", "repeats_bond",
           "reduce_pass", "rod_pass", "sphere_pass", "spine_gap", "worst_overlap"]
