//! How a body is wrapped onto a surface: the search band, the creases' room, what becomes
//! loose cloth and where crossing faces are spanned; and which mesh stands for an avatar.

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WrapOptions {
    /// How far (metres) inside the body and outside it the surface is looked for along each
    /// vertex normal, and the step of that search.
    pub inside: f32,
    pub outside: f32,
    pub step: f32,
    /// An extracted surface is covered by the wrapped body when no more than `max_uncovered` of
    /// its area lies farther than `far` (metres) from it.
    pub far: f32,
    pub max_uncovered: f32,
    /// Beside loose pieces the body is wrapped only this far out (metres): a thigh under a
    /// skirt must not be pulled onto the skirt.
    pub tight_outside: f32,
    /// A loose piece's border vertices this close (metres) to the wrapped body are put on it,
    /// so a skirt meets the hips without a gap.
    pub seam: f32,
    /// Loose pieces with less area than this share of the rest body's surface are dropped:
    /// fragments of the extracted surface, not clothing. 2 % is a 15 x 23 cm patch on an
    /// adult; a fitted dress's fragments (round the hem, between the skirt and the thighs,
    /// under the arms) are 10-350 cm^2 and most of their area lies more than 2 cm from the
    /// true cloth at held-out poses (docs/decisions.md), while a skirt is about
    /// 0.9 m^2 and a blazer's tails about 0.5 m^2.
    pub min_piece_share: f32,
    /// The faces far from the wrapped body are chosen one by one, which frays a piece's
    /// border: the bits of them with less area than this share of the rest body's surface
    /// (joined to the rest by a vertex at most; 0.5 % is about 90 cm^2 on an adult) are
    /// dropped, and holes shorter than `max_hole` (metres: where the cloth passed near the
    /// body, a thigh under a skirt) are closed.
    pub min_shred_share: f32,
    pub max_hole: f32,
    /// Where the body is thinner than this (metres, along the inward normal: fingers, ears)
    /// it is not wrapped: the depth and the SDF's grid cannot resolve it, and the body's own
    /// surface is the better guess than the blob around it.
    pub thin: f32,
    /// Each offset stays within this share of the room the body leaves on its side
    /// (`reach_out`, `reach_in`): an offset surface folds over itself once it passes the
    /// centre of the largest ball that touches the body there, and in the creases of a face
    /// (eyelids, nostrils, the ear's folds) that ball is millimetres wide, where a depth camera
    /// sees nothing finer than a centimetre.
    pub crease_share: f32,
    /// Loose pieces that hang round the body (a skirt, a coat's tails, a cape) are remade as
    /// one whole sheet (`canonical::garment_sheet`) instead of kept as extracted.
    pub remesh_loose: bool,
    /// Where faces of the smoothed wrapped surface that pass through others are spanned as a
    /// membrane ([`super::BodyWrap::span_crossings`]): on the head (eyelids, lips, nostrils, where
    /// the depth says little). Not where two parts of the body press together (the crotch,
    /// the armpits): the true garments cross there too, and spanning them everywhere cost the
    /// tight outfit's NC 0.935 -> 0.930 (docs/integrity.md, "Crossing faces spanned").
    pub span_crossings: SpanCrossings,
}

impl Default for WrapOptions {
    fn default() -> Self {
        // The band reaches a loose polo (up to about 4 cm off the body); a step of 2 mm keeps
        // the search at 41 SDF values a vertex, the surface between two of them found by
        // linear interpolation (the SDF is close to linear over 2 mm).
        WrapOptions {
            inside: 0.02,
            outside: 0.06,
            step: 0.002,
            far: 0.015,
            max_uncovered: 0.03,
            tight_outside: 0.035,
            seam: 0.03,
            min_piece_share: 0.02,
            min_shred_share: 0.005,
            max_hole: 0.3,
            thin: 0.03,
            crease_share: 0.8,
            remesh_loose: true,
            span_crossings: SpanCrossings::Head,
        }
    }
}

/// Which mesh stands for an avatar's surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurfaceChoice {
    /// The wrapped body where it covers the extracted surface (tight clothing), else the
    /// extracted mesh.
    #[default]
    Auto,
    /// Marching cubes of the SDF.
    Extracted,
    /// The body's mesh wrapped onto the surface.
    WrappedBody,
    /// The body's mesh wrapped onto the surface where the clothing is tight and left on the
    /// body elsewhere (the legs under a skirt), with the extracted mesh's loose pieces (the
    /// skirt, a blazer's tails) beside it ([`super::BodyWrap::with_loose_pieces`]).
    WrappedWithLoose,
}

/// Which vertices of a wrapped surface may move to span its crossing faces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpanCrossings {
    Nowhere,
    /// The vertices whose dominant joint is the neck or the head.
    Head,
    Everywhere,
}
