//! Synthetic clothed humans: outfits, pose-dependent clothing deformation, depth rendering, ground truth.
