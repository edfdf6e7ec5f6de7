"""friction-bench domain core: LuGre model, identification, analysis, compensation, records."""
__version__ = "0.1.0"
