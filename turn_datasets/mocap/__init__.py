"""Motion capture: dataset discovery and one reader per format (Human3.6M CDF/h5/npz, BVH, arrays)."""
