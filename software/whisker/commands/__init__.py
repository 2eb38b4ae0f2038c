"""One module per `whisker` subcommand; each exposes `cli` (a click command or group).

Keep heavy imports inside the command functions so that `whisker --help` stays fast.
"""
