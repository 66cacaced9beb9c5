use super::*;

#[test]
fn only_a_moving_view_on_a_software_renderer_is_drawn_smaller() {
    assert_eq!(render_scale(true, true), SOFTWARE_MOVING_SCALE);
    const {
        assert!(
            SOFTWARE_MOVING_SCALE < 1.0 && SOFTWARE_MOVING_SCALE >= 0.5,
            "a moving view stays recognisable"
        )
    };
    assert_eq!(render_scale(true, false), 1.0, "still: every pixel (the look of the screenshots)");
    assert_eq!(render_scale(false, true), 1.0, "a GPU draws every pixel");
    assert_eq!(render_scale(false, false), 1.0);
}

#[test]
fn scaled_sizes_round_and_stay_positive() {
    assert_eq!(scaled_size([787, 714], 1.0), [787, 714]);
    assert_eq!(scaled_size([787, 714], 0.5), [394, 357]);
    assert_eq!(scaled_size([1, 3], 0.25), [1, 1]);
}
