"""The one pattern every observable follows (after freud and MDAnalysis).

Parameters go to ``__init__``; ``compute(...)`` does the work on one frame and returns
``self``; results are attributes that raise :class:`NotComputedError` until ``compute``
ran::

    cn = ContactNumber(c_min=4).compute(frame, contacts)
    cn.z_rattler_free

Over many frames, :meth:`Observable.run` calls ``compute`` for each and collects the
scalar results per frame in a :class:`pandas.DataFrame` (one row per frame, a ``step``
column first)::

    table = ContactNumber(c_min=4).run(RunData(d).frames(), ["z", "z_rattler_free"])

Frame-based observables take ``compute(frame, contacts=None)``; those that need
contacts say so when they are missing.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence


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

    def __setattr__(self, name, value):
        if name in type(self)._results:
            raise AttributeError(f"{type(self).__name__}: {name!r} is a result name; store "
                                 "parameters under another name")
        super().__setattr__(name, value)

    @property
    def results(self) -> dict:
        """All results computed so far, by name (empty before ``compute``)."""
        return {k: self.__dict__["_r_" + k] for k in self._results if "_r_" + k in self.__dict__}

    def compute(self, *args, **kwargs):  # pragma: no cover - interface
        raise NotImplementedError

    def run(self, frames: Iterable, results: Sequence[str]):
        """``compute`` on every item of ``frames`` and collect ``results`` per frame.

        Items are frames or tuples ``(frame, contacts, ...)`` (as yielded by
        :meth:`analysis.io.RunData.frames`), unpacked into ``compute``. Returns a
        DataFrame with a ``step`` column (the first argument's ``step``) and one column
        per requested result (scalars; arrays are stored as objects).
        """
        import pandas as pd

        bad = [r for r in results if r not in self._results]
        if bad:
            raise KeyError(f"{type(self).__name__} has no results {bad}; valid: "
                           f"{list(self._results)}")
        rows = []
        for item in frames:
            args = item if isinstance(item, tuple) else (item,)
            self.compute(*args)
            row = {"step": getattr(args[0], "step", len(rows))}
            row.update({r: getattr(self, r) for r in results})
            rows.append(row)
        return pd.DataFrame(rows, columns=["step", *results])
