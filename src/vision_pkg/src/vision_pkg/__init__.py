"""Sense layer, vision: stereo head and hand camera capture, tomato detection and the image_processing action server."""
