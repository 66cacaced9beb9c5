//! Captures: the capture folder format, depth/fitting loaders, back-projection, normals, cropping, AMASS import.
