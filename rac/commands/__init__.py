"""One module per ``racc`` command; helpers they share live in ``rac.commands.common``."""
