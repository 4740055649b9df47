"""rodpack analysis: observables of granular packings, identical for every engine.

Read a run with :class:`analysis.io.RunData`; observables are compute objects
(:mod:`analysis.base`) or pure functions on plain arrays.
"""
from analysis.frame import Contacts, Frame

__all__ = ["Contacts", "Frame"]
