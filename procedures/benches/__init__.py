"""Built-in bench configurations (package data)."""
