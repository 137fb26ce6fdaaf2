"""Subcommands of the ``omegahat`` command: each module has ``HELP``, ``add_arguments(parser)`` and ``run(args)``."""
