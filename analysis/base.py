"""The one pattern every observable follows (after freud and MDAnalysis).

Parameters go to ``__init__``; ``compute(...)`` does the work and returns ``self``;
results are attributes that raise :class:`NotComputedError` until ``compute`` ran::

    cn = ContactNumber(z_min=4).compute(frame, contacts)
    cn.z_rattler_free
"""
from __future__ import annotations


class NotComputedError(AttributeError):
    """A result was read before ``compute`` was called."""


class Observable:
    """Base class: subclasses list their result names in ``_results`` and set them in
    ``compute`` with :meth:`_set`."""

    _results: tuple[str, ...] = ()

    def _set(self, **values):
        for k, v in values.items():
            if k not in self._results:
                raise KeyError(f"{type(self).__name__} has no result {k!r}")
            self.__dict__["_r_" + k] = v

    def __getattr__(self, name):
        if name in type(self)._results:
            try:
                return self.__dict__["_r_" + name]
            except KeyError:
                raise NotComputedError(
                    f"{type(self).__name__}.{name} is not available: call compute() first") from None
        raise AttributeError(name)

    def compute(self, *args, **kwargs):  # pragma: no cover - interface
        raise NotImplementedError
