"""The laboratory's commands (``omegahat paper``, ``compare``, ``montecarlo``, ``control``), dispatched by
:mod:`omegahat.cli` like ``omegahat estimate``."""
