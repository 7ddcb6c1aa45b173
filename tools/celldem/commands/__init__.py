"""The command-line tools, each a module with main(argv=None) -> exit status: the installed commands
(pyproject.toml's [project.scripts]: celldem-report, celldem-figures, ...) and the scripts tools/<name>.py of a
checkout, which only call them."""
