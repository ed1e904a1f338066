"""Shared test helpers, imported as ``from helpers import zoo`` (pytest puts tests/ on the path).

- zoo: the mechanisms every stage is tested on (pendulums, chains, rolling disc, ...)
- random_chains: random serial chains for property tests
- model_files, osc_model: model files and a hand-written oscillator library for CLI/loader tests
- cache_entries: fake cache entries for the cache tests
- emit_support: compile generated C with warnings as errors, header paths
- state_models: mechanisms and model files with extra first-order states (motors, muscles)
- kane_oracle, lagrange_mechanisms, lagrange_numeric: independent derivations to compare against
- stand_in, spies: hand-written C models (tests/runtime/models/*.c) for the integrators, and call spies
"""
