"""Turn-REMAP: ELAN reading, the annotation schema, labels, inter-rater agreement."""
