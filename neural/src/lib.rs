//! The neural avatar (MetaAvatar): meta-learned SDF and hypernetwork, fitting and posing.
