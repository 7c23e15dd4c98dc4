"""app: the avhear application (configuration, sources, threads, Rerun logging, command line)."""
