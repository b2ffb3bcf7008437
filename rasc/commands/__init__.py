"""Sub-commands of the ``rasc`` command line; see :mod:`rasc.cli`."""
