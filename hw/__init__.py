"""The hardware folder, shipped as the data package ``whisker.hw`` (default design, printer
profile, tables). Nothing to import here: whisker.resources finds the files."""
