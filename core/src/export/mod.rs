//! Export: animated binary glTF of an avatar, OBJ/PLY sequences.
