//! Canonicalization: diffused skinning field, inverse skinning by root finding, canonical normalisation.
