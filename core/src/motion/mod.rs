//! Motion clips: a sequence of body parameters at a frame rate; the procedural clip library; clip files.
