//! Evaluation: MetaAvatar's metrics (Dp, Df, NC), IoU, Chamfer, protocols and reports.
