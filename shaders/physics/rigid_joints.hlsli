// Joint constraints: attachment, axis/orientation alignment, limits and drives.
// Expects `joints`, `joint_targets`, `joint_lambdas`, `reaction_forces`, `reaction_torques` and
// rigid_bodies.hlsli.

struct JointFrames {
  float3 pa, pb;  // joint frame origins in world, on a and on b
  float4 qa, qb;  // joint frame rotations in world
  float3 ra, rb;  // arms from the body origins
};

JointFrames joint_frames(JointModel j) {
  JointFrames f;
  const uint a = j.ids.x, b = j.ids.y;
  f.qa = quat_mul(body_rotation(a), j.frame_a_rotation);
  f.qb = quat_mul(body_rotation(b), j.frame_b_rotation);
  f.ra = quat_rotate(body_rotation(a), j.frame_a_position.xyz);
  f.rb = quat_rotate(body_rotation(b), j.frame_b_position.xyz);
  f.pa = body_position(a) + f.ra;
  f.pb = body_position(b) + f.rb;
  return f;
}

// the joint's coordinate: hinge angle of frame b about frame a's x, or slider offset along it
float joint_coordinate(JointModel j, JointFrames f) {
  const uint kind = j.ids.z;
  const float3 axis = quat_rotate(f.qa, float3(1, 0, 0));
  if (kind == JOINT_SLIDER) return dot(f.pb - f.pa, axis);
  if (kind == JOINT_HINGE) {
    const float3 ya = quat_rotate(f.qa, float3(0, 1, 0)), yb = quat_rotate(f.qb, float3(0, 1, 0));
    return atan2(dot(cross(ya, yb), axis), dot(ya, yb));
  }
  return 0;
}

float wrap_angle(float x) {
  const float two_pi = 6.28318530718;
  return x - two_pi * floor((x + 3.14159265359) / two_pi);
}

// impulses the joint applied to body a this substep (b got their negatives)
struct JointImpulse {
  float3 positional;  // kg m, at the joint frame origins
  float3 angular;     // kg m^2
};

// a correction of `error` along the joint axis: a translation (slider) or a turn (hinge)
void drive_axis(JointModel j, JointFrames f, float3 axis, float error, float alpha, inout float lambda,
                float max_lambda, inout JointImpulse impulse) {
  if (error == 0) return;
  if (j.ids.z == JOINT_SLIDER)
    impulse.positional += correct_position(j.ids.x, j.ids.y, f.ra, f.rb, error * axis, alpha, lambda, max_lambda);
  else
    impulse.angular += correct_rotation(j.ids.x, j.ids.y, error * axis, alpha, lambda, max_lambda);
}

// rotation vector that turns frame a onto frame b (what a must turn by)
float3 orientation_error(JointFrames f) {
  float4 d = quat_mul(f.qb, quat_conj(f.qa));
  if (d.w < 0) d = -d;
  return 2.0 * d.xyz;
}

// Projects joint j once. h: substep; prev_coordinate: at the substep start (drives need it).
void solve_joint(uint ji, float h, float prev_coordinate) {
  const JointModel j = joints[ji];
  const uint a = j.ids.x, b = j.ids.y, kind = j.ids.z;
  const uint mode = j.ids.w >> 8;
  const bool limited = (j.ids.w & JOINT_LIMITED) != 0;
  const float inv_h2 = 1.0 / (h * h);
  const float joint_alpha = j.drive.w * inv_h2;
  const float big = 3.4e38;
  float4 lambda = joint_lambdas[ji];
  JointImpulse impulse;
  impulse.positional = float3(0, 0, 0);
  impulse.angular = float3(0, 0, 0);

  // orientation: all three axes (fixed, slider), the hinge axis only, or none (ball)
  JointFrames f = joint_frames(j);
  if (kind == JOINT_FIXED || kind == JOINT_SLIDER) {
    impulse.angular += correct_rotation(a, b, orientation_error(f), joint_alpha, lambda.y, big);
  } else if (kind == JOINT_HINGE) {
    const float3 xa = quat_rotate(f.qa, float3(1, 0, 0)), xb = quat_rotate(f.qb, float3(1, 0, 0));
    impulse.angular += correct_rotation(a, b, cross(xa, xb), joint_alpha, lambda.y, big);
  }

  // attachment: the frame origins meet (along the slider axis they may part)
  f = joint_frames(j);
  float3 gap = f.pb - f.pa;
  if (kind == JOINT_SLIDER) {
    const float3 axis = quat_rotate(f.qa, float3(1, 0, 0));
    gap -= dot(gap, axis) * axis;
  }
  impulse.positional += correct_position(a, b, f.ra, f.rb, gap, joint_alpha, lambda.x, big);

  if (kind == JOINT_HINGE || kind == JOINT_SLIDER) {
    // limits, then the drive, both along the joint axis
    f = joint_frames(j);
    const float3 axis = quat_rotate(f.qa, float3(1, 0, 0));
    float s = joint_coordinate(j, f);
    float excess = 0;
    if (limited && s < j.limits.x) excess = s - j.limits.x;
    if (limited && s > j.limits.y) excess = s - j.limits.y;
    if (excess != 0) drive_axis(j, f, axis, excess, 0, lambda.z, big, impulse);
    if (mode != DRIVE_NONE) {
      f = joint_frames(j);
      s = joint_coordinate(j, f);
      const float target = joint_targets[ji].x;
      const float max_lambda = j.drive.z * h * h;
      float error = 0, alpha = 0;
      if (mode == DRIVE_POSITION && j.drive.x > 0) {
        error = s - target;
        if (kind == JOINT_HINGE) error = wrap_angle(error);
        alpha = inv_h2 / j.drive.x;
        drive_axis(j, f, axis, error, alpha, lambda.w, max_lambda, impulse);
      }
      // damping toward the target velocity (velocity mode) or toward rest (position mode):
      // the substep's displacement should be v * h; damping d acts as a stiffness d / h on it
      if (j.drive.y > 0) {
        f = joint_frames(j);
        float moved = joint_coordinate(j, f) - prev_coordinate;
        if (kind == JOINT_HINGE) moved = wrap_angle(moved);
        const float v = mode == DRIVE_VELOCITY ? target : 0;
        float damping_lambda = 0;
        drive_axis(j, f, axis, moved - v * h, inv_h2 * h / j.drive.y, damping_lambda, max_lambda, impulse);
      }
    }
  } else if (kind == JOINT_SPHERICAL && mode == DRIVE_POSITION && j.drive.x > 0) {
    // turn the relative rotation (b in a's joint frame) toward the target quaternion
    f = joint_frames(j);
    float4 e = quat_mul(quat_mul(quat_conj(f.qa), f.qb), quat_conj(joint_targets[ji]));
    if (e.w < 0) e = -e;
    impulse.angular +=
        correct_rotation(a, b, quat_rotate(f.qa, 2.0 * e.xyz), inv_h2 / j.drive.x, lambda.w, j.drive.z * h * h);
  }
  joint_lambdas[ji] = lambda;
  // the reaction on b (summed over the frame's substeps, averaged at its end): positional
  // impulses act at b's joint frame origin, so only the angular ones turn b about it
  reaction_forces[ji].xyz -= impulse.positional * inv_h2;
  reaction_torques[ji].xyz -= impulse.angular * inv_h2;
}
