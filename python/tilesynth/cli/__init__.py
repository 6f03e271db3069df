"""The ``tilesynth`` command line: commands, option types, material flags, batch builds and export."""
