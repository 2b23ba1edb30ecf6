"""Wiring: builds the populations and synapses of the CPG from ``astrocpg.models``, one group per
row of the population table (:mod:`astrocpg.network.populations`)."""

from . import populations

from .build import CPG, build_cpg, built_in_models, check_runs, same_limb_mask, trial_seeds
from .codegen import codegen_target, use_codegen
from .delays import delay_steps, limb_stages
from .divergence import (LIMIT, DivergenceCheck, InvalidState, NonFinite, StateScan,
                         find_diverged, invalid, network_time, run_network)
from .layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS, Layout, interlimb_labels
from .parts import Part, TrialTable
from .runlock import RUN_LOCK, exclusive

__all__ = ["populations", "CPG", "build_cpg", "built_in_models", "check_runs", "same_limb_mask", "trial_seeds",
           "Layout", "LEGS", "POOLS", "THIGH_POOLS", "INTERNEURONS", "interlimb_labels",
           "DivergenceCheck", "NonFinite", "InvalidState", "StateScan", "LIMIT", "invalid",
           "find_diverged", "network_time", "run_network",
           "codegen_target", "use_codegen", "delay_steps", "limb_stages", "Part", "TrialTable",
           "RUN_LOCK", "exclusive"]
