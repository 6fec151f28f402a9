"""Data layer: upload of local records to the farm server."""
