"""Planning: the league NLP built once per structure, and the solver that runs it safely.

A map, in reading order:

* ``layout`` — a league problem's sizes (``Structure``), its per-step inputs by name
  (``ProblemInputs``; zone rows and weights with named columns) and where each sits in the
  solver's flat parameter and decision vectors;
* ``margins`` — the keep-out margin of the chance constraints (eqs. 7c/7d), symbolic and numeric;
* ``pieces`` — the NLP's small pieces (sensor information, trace, margin, distance) with their
  derivatives; the sensor's own model is in ``models.sensor``;
* ``nlp`` — ``LeagueNLP``: objective terms and constraint rows assembled step by step;
  ``hessian`` — assembling and convexifying its Hessian;
* ``reduction`` — the SQP's smaller problem with the same solutions for large leagues;
* ``solver_options`` — solver settings and ``ProblemOptions``;
* ``league_problem`` — ``LeagueProblem``: solvers for one structure and one solve, on
  ``compiled_problem`` — solvers per method on compiled code when it is ready (shared with the
  SOG problem); ``compiled_call`` — the flat-buffer call of a solver; ``nlp_cache`` — problems
  shared process-wide; ``cache`` — the LRU cache;
* ``codegen`` — C code for a problem's functions, compiled in the background: the library
  cache on disk (``library_cache``), its index by what defines the functions
  (``library_index``), the compile jobs this process owns (``compile_jobs``) and the program
  supervising one compile (``compile_supervisor``);
* ``planner`` — the never-crashing solver ladder; ``safe_action`` — its last rung;
* ``adaptation``, ``evasion`` — the failure-aware policy's weights and circling;
* ``sog_problem`` — the SOG baseline's program and planner, ``sog_nlp`` — its symbolic problem
  on the fast path (compiled, SQP ladder); ``faults`` — solver-fault injection for tests.
"""
