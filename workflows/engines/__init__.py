"""Driving LAMMPS and LIGGGHTS with a rodpack case, and turning what they write into
the common format (``docs/formats.md``).

Which engine runs which case, and how, is one table (:mod:`~workflows.engines.table`):
an adapter per supported (engine, shape, protocol) names the deck in ``inputs/<engine>/``,
the builder of its ``-var`` values, the data file it reads, the converter of its output,
whether a stopped run resumes, and what the deck cannot do. The engine modules hold
those pieces (:mod:`~workflows.engines.lammps`, :mod:`~workflows.engines.liggghts`,
:mod:`~workflows.engines.pysim`), with what they share in
:mod:`~workflows.engines.common`, :mod:`~workflows.engines.data` (data files),
:mod:`~workflows.engines.convert` (reading their output) and
:mod:`~workflows.engines.restarts`; :func:`run` (:mod:`~workflows.engines.driver`) runs an
adapter in a work directory. A run that fails, hangs past its budget or loses atoms raises
:class:`EngineError` naming the engine's own error line and its log.

This package keeps the names its callers use; they live in the modules named above.
"""
from workflows.engines.common import (INPUTS, PROJECT_ROOT, SHAPES, EngineError, glued_spheres,
                                      shape, venv_bin)
from workflows.engines.data import RHO_2D, write_body_data, write_glued_data
from workflows.engines.driver import (ERROR_HINTS, JOB_STEP_PREFIXES, command, engine_env,
                                      engine_version, failure_message, run)
from workflows.engines.lammps import (GLUED_WALLS, convert_body_rods, convert_glued_rods,
                                      convert_lammps_contacts, deck_vars_2d, deposit_deck_vars,
                                      glued_wall_contacts, tap_deck_vars)
from workflows.engines.liggghts import (E_MIN, LIGGGHTS_TAP_WALLS, MULTISPHERE_WALLS,
                                        PHI_INSERT, PHI_INSERT_SETTLE, SETTLE_FLOOR_ID,
                                        convert_liggghts_contacts, convert_liggghts_tap,
                                        convert_multisphere_rods, convert_settled_rods,
                                        floor_contacts, hertz_restitution,
                                        liggghts_column_height, liggghts_deposit_support,
                                        liggghts_deposit_vars, liggghts_latest_restart,
                                        liggghts_restart_is_complete, liggghts_settle_support,
                                        liggghts_settle_vars, liggghts_tap_column,
                                        liggghts_tap_support, liggghts_tap_vars,
                                        liggghts_tap_wall_contacts, multisphere_wall_contacts,
                                        restore_box_precision, settle_column_height,
                                        settle_plan)
from workflows.engines.restarts import (KEEP_RESTARTS, RESTART_DUMPS,
                                        cut_outputs, latest_restart, prune_restarts,
                                        restart_interval, restart_is_complete, resumable,
                                        resume_stamp)
from workflows.engines.table import (ADAPTERS, ENGINES, PROTOCOLS, Adapter, deck, deck_vars,
                                     lookup, settles, supports)
