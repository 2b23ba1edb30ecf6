"""Wiring: the CPG's populations and synapses built from ``astrocpg.models`` for ``n_trials``
independent copies (``build``: :func:`build_cpg`, :class:`CPG`), one group per row of the
population table (``populations``), their index layout (legs, pools, interneurons: ``layout``,
``parts``), what a run can record (the rows' spikes and traces), the stages of limbs that 0 ms
inter-limb delays make (``delays``), the divergence scan of the state (``divergence``), Brian2's
code-generation target (``codegen``), and the run lock that lets one build-and-run use Brian2
at a time in a process and applies the framework's Brian2 settings only while it does
(``runlock``, ``brian_prefs``). Nothing here is biophysics."""

from . import populations

from .build import build_cpg, built_in_models, check_runs
from .cpg import CPG, same_limb_mask, trial_seeds
from .codegen import codegen_target, use_codegen
from .delays import delay_steps, limb_stages
from .divergence import (LIMIT, DivergenceCheck, InvalidState, StateScan,
                         find_diverged, invalid, network_time, run_network)
from .layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS, Layout, interlimb_labels
from .trial_tables import Part, TrialTable
from .runlock import RUN_LOCK, exclusive

__all__ = ["populations", "CPG", "build_cpg", "built_in_models", "check_runs", "same_limb_mask", "trial_seeds",
           "Layout", "LEGS", "POOLS", "THIGH_POOLS", "INTERNEURONS", "interlimb_labels",
           "DivergenceCheck", "InvalidState", "StateScan", "LIMIT", "invalid",
           "find_diverged", "network_time", "run_network",
           "codegen_target", "use_codegen", "delay_steps", "limb_stages", "Part", "TrialTable",
           "RUN_LOCK", "exclusive"]
