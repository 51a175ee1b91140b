// The arm tasks' actions (TissueRetract, BloodSuction), included after their `actions` and
// `arm_limits` declarations: arm_limits holds (3, joints) rows, the lower and upper joint limits
// and the target step per unit action.

// action k of env's row of `width`: NaN counts as 0, clamped to [-1, 1]
float action(uint env, uint k, uint width) {
  const float a = actions[width * env + k];
  return isnan(a) ? 0.0 : clamp(a, -1.0, 1.0);
}

// joint k's new target from its target q and action a, within its limits
float joint_target(float q, float a, uint k, uint joints) {
  return clamp(q + a * arm_limits[2 * joints + k], arm_limits[k], arm_limits[joints + k]);
}
