"""The parsers of the ``railgym`` subcommands that build elements and docs: one module per
subcommand, each with ``build_parser()`` and ``main(argv)`` calling the plain functions of the
physics and env packages (which hold no parser). The subcommands are listed in
:data:`agents.commands.cli.MODULE_COMMANDS`."""
