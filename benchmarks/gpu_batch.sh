#!/usr/bin/env bash
# The GPU machine's whole session in stages (device time is scarce: one call per stage or two).
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh setup tests      # build, ctest, pytest
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-a           # CartPole, rendering
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-b bench-twin  # ultrasound; the twin
#   source .gpu/prelude.sh; CRESSIM_TESTS=OFF bash benchmarks/gpu_batch.sh setup bench-policy  # issue 19
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-policy-ppo  # issue 19: PPO, training
#   source .gpu/prelude.sh; CRESSIM_TESTS=OFF bash benchmarks/gpu_batch.sh setup bench-fused  # issue 19: fused update
#   source .gpu/prelude.sh; CRESSIM_TESTS=OFF bash benchmarks/gpu_batch.sh setup bench-cnn  # issue 19: the CNN
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-twin-tissue  # the twin over tissue
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-cart  # the patient cart (ECM, 3 PSMs, stereo)
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-heat  # the cautery scene; the twin's tick
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-sew   # the continuum robot and suture scenes
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-soft bench-fluid  # SoftBodyPush, FluidPour
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-soft-material      # elastic tets' cost
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-surgical  # TissueRetract, BloodSuction
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-r bench-us  # render extras, ultrasound
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-us-scale    # ultrasound phantoms of 1 M and 10 M
#   source .gpu/prelude.sh; bash benchmarks/gpu_batch.sh bench-pr          # particles drawn by the renderer
#   source .gpu/prelude.sh; CRESSIM_TESTS=OFF bash benchmarks/gpu_batch.sh setup bench-tc bench-ppo  # PPO
# Results (text and JSON) go to $OUT/r (default out/gpu/r). Each command has its own time limit, so
# one slow run cannot eat the stage. `setup` also installs the pure-Python wheels the twin's
# kinematics need (.gpu-wheels, made on the development machine: benchmarks/README.md) into
# .gpu-py, since the GPU machine reaches no registry.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-out/gpu}
# only a few files come back from the GPU machine: logs and results go under $OUT/r, and the
# archive $OUT/gpu_results.tgz of it is refreshed after every run, so a stage cut short by the
# time limit still returns what it measured
TOP=$OUT
OUT=$TOP/r
mkdir -p "$OUT"
export PYTHONPATH=python:ros_ws/src/cressim_ros:.gpu-py
ulimit -n "$(ulimit -Hn)" 2>/dev/null  # every Vulkan device on the NVIDIA driver holds a few fds

run() {  # run NAME SECONDS CMD...: output to $OUT/NAME.txt, a line per run to $OUT/runs.txt
  local name=$1 limit=$2
  shift 2
  local t0=$SECONDS
  timeout "$limit" "$@" > "$OUT/$name.txt" 2>&1
  local rc=$?
  echo "$name rc=$rc $((SECONDS - t0))s: $*" | tee -a "$TOP/runs.txt"
  tar czf "$TOP/gpu_results.tgz" -C "$OUT" .
}

for stage in "$@"; do
  case $stage in
    setup)
      run build 400 env CRESSIM_TESTS=${CRESSIM_TESTS:-ON} bash benchmarks/gpu_build.sh
      [ -d .gpu-wheels ] && run wheels 120 python3 -m pip install -q --no-index --no-deps --target .gpu-py .gpu-wheels/*.whl
      run info 60 python3 -m cressim info
      ;;
    tests)
      run ctest 200 bash -c "cd build/gpu && ctest --output-on-failure"
      # a process per folder: what one folder leaves behind in the driver cannot fail another's
      for d in gpu scene compute runtime physics render sensors particles envs; do
        [ -d tests/$d ] && run pytest_$d 240 env CRESSIM_VALIDATION=1 python3 -m pytest -v -p no:cacheprovider tests/$d
      done
      ;;
    verify)  # the folders a change touched, after a fix
      for d in ${VERIFY:-render envs}; do
        run pytest_$d 240 env CRESSIM_VALIDATION=1 python3 -m pytest -q -p no:cacheprovider tests/$d
      done
      ;;
    bench-a)
      run cartpole 120 python3 -m cressim bench CartPole --envs 256 --mode both --device cuda --minibatch 262144 \
        --out "$OUT"
      run render 150 python3 benchmarks/bench_render.py --envs 1024,4096,8192 --sizes 64 --raster both \
        --frames 50 --json "$OUT/render2_64.json"
      run render_sizes 100 python3 benchmarks/bench_render.py --envs 4096 --sizes 128,256 --raster both \
        --frames 30 --json "$OUT/render2_sizes.json"
      run render_rgb 100 python3 benchmarks/bench_render.py --envs 4096,8192 --sizes 64 --raster both \
        --products rgb --frames 50 --json "$OUT/render2_rgb.json"
      mkdir -p "$OUT/targetcenter_graphics" "$OUT/targetcenter_compute"
      run targetcenter 120 python3 -m cressim bench TargetCenter --envs 256,1024,4096,8192 --mode step \
        --out "$OUT/targetcenter_graphics"
      run targetcenter_compute 120 env CRESSIM_RASTER=compute python3 -m cressim bench TargetCenter \
        --envs 256,1024,4096,8192 --mode step --out "$OUT/targetcenter_compute"
      ;;
    bench-policy)  # issue 19: the policy in the engine's frame; the CUDA -> Vulkan hand-off
      run pytest_engine_policy 200 env CRESSIM_VALIDATION=1 python3 -m pytest -q -p no:cacheprovider \
        tests/learn/test_engine_policy.py tests/learn/test_engine_rollout.py tests/learn/test_bench_smoke.py \
        tests/learn/test_cuda_graph_ppo.py
      run handoff 120 python3 benchmarks/bench_handoff.py --envs 8192 --json "$OUT/handoff.json"
      mkdir -p "$OUT/policy"
      run cartpole_policy 270 python3 -m cressim bench CartPole --envs 1024,4096,8192,16384 --mode all --device cuda \
        --out "$OUT/policy"
      ;;
    bench-cnn)  # issue 19: TargetCenter's CNN actor in the engine's frame (engine_cnn.py)
      run pytest_engine_cnn 300 env CRESSIM_VALIDATION=1 python3 -m pytest -q -p no:cacheprovider \
        tests/learn/test_engine_cnn.py tests/learn/test_engine_policy.py tests/learn/test_engine_rollout.py
      mkdir -p "$OUT/tc_policy" "$OUT/tc_ppo_engine"
      run tc_policy 400 python3 -m cressim bench TargetCenter --envs 32,256,1024 --mode policy --device cuda \
        --out "$OUT/tc_policy"
      run tc_engine_cnn 300 python3 benchmarks/bench_engine_cnn.py TargetCenter --envs 32,256,1024 \
        --steps-per-submit 1,8,32,128 --json "$OUT/tc_engine_cnn.json"
      run tc_ppo_engine 300 python3 -m cressim bench TargetCenter --envs 32,256 --mode ppo --policy engine \
        --device cuda --out "$OUT/tc_ppo_engine"
      run tc_train_engine_rollout 300 python3 -m cressim train TargetCenter --envs 256 --iterations 20 \
        --engine-rollout --device cuda --save-every 20 --out "$OUT/tc_train_engine_rollout"
      ;;
    bench-policy-ppo)  # issue 19: PPO with the actor in torch, in the engine with a compiled learner; training
      mkdir -p "$OUT/policy_torch_ppo" "$OUT/policy_compiled_ppo"
      run cartpole_ppo_torch 150 python3 -m cressim bench CartPole --envs 8192 --mode ppo --policy torch --device cuda \
        --out "$OUT/policy_torch_ppo"
      run cartpole_ppo_compiled 250 python3 -m cressim bench CartPole --envs 8192 --mode ppo --compile --device cuda \
        --out "$OUT/policy_compiled_ppo"
      run train_engine_rollout 200 python3 -m cressim train CartPole --envs 8192 --iterations 60 --engine-rollout \
        --device cuda --save-every 60 --out "$OUT/train_engine_rollout"
      ;;
    bench-fused)  # issue 19: PPO's update as fused Triton kernels (learn/fused_update.py) against torch's
      run pytest_fused 200 env CRESSIM_VALIDATION=1 python3 -m pytest -v -p no:cacheprovider \
        tests/learn/test_fused_update.py tests/learn/test_cuda_graph_ppo.py tests/learn/test_engine_rollout.py
      mkdir -p "$OUT/ppo_fused" "$OUT/ppo_unfused" "$OUT/ppo_fused_particles"
      run cartpole_ppo_fused 300 python3 -m cressim bench CartPole --envs 1024,4096,8192,16384 --mode ppo \
        --device cuda --out "$OUT/ppo_fused"
      run cartpole_ppo_unfused 150 python3 -m cressim bench CartPole --envs 8192 --mode ppo --fused-update off \
        --device cuda --out "$OUT/ppo_unfused"
      run train_fused 200 python3 -m cressim train CartPole --envs 8192 --iterations 60 --engine-rollout \
        --device cuda --save-every 60 --out "$OUT/train_fused"
      for spec in "SoftBodyPush 512" "FluidPour 128"; do
        read -r task counts <<< "$spec"
        run "ppo_fused_$task" 200 python3 -m cressim bench "$task" --envs "$counts" --mode ppo --device cuda \
          --out "$OUT/ppo_fused_particles"
      done
      run pytest_learn_smoke 200 env CRESSIM_VALIDATION=1 python3 -m pytest -v -p no:cacheprovider \
        tests/learn/test_bench_smoke.py tests/learn/test_train_smoke.py
      ;;
    bench-b)
      mkdir -p "$OUT/ultrasound" "$OUT/ultrasound_sweep"
      run ultrasound 200 python3 -m cressim bench UltrasoundScan --envs 1,8,32,64 --mode both --out "$OUT/ultrasound"
      run ultrasound_sweep 150 python3 -m cressim bench UltrasoundScan --envs 128,256,512,1024 --mode step \
        --out "$OUT/ultrasound_sweep"
      run ultrasound_sensor 120 python3 benchmarks/bench_ultrasound.py --envs 1,32,256,1024,4096 \
        --json "$OUT/ultrasound_sensor.json"
      ;;
    bench-twin)  # the twin's 100 Hz tick with the default scene's 640x480 camera per env at 30 Hz
      run twin 600 python3 benchmarks/bench_twin.py --envs 1,64,1024 --seconds 10 --json "$OUT/twin.json"
      ;;
    bench-cart)  # the patient cart: ECM + 3 PSMs, stereo 640x480 at 30 Hz (issue 17)
      run cart 300 python3 benchmarks/bench_cart.py --seconds 10 --json "$OUT/cart.json"
      ;;
    bench-twin-tissue)  # the twin over the retraction scene's flap: kinematic at 200 Hz physics, dynamic at 800
      run twin_tissue 300 python3 benchmarks/bench_twin.py --scene psm_retraction.yaml --envs 1,16 \
        --dynamics kinematic --seconds 5 --json "$OUT/twin_tissue.json"
      run twin_tissue_dynamic 300 python3 benchmarks/bench_twin.py --scene psm_retraction.yaml --envs 1,16 \
        --dynamics dynamic --physics-rate 800 --seconds 5 --json "$OUT/twin_tissue_dynamic.json"
      ;;
    bench-heat)  # cressim demo cautery's scene with and without heat; where a twin tick over tissue goes
      run cautery 300 python3 benchmarks/bench_cautery.py --envs 1,64,1024 --json "$OUT/cautery.json"
      run profile_twin 300 python3 benchmarks/profile_twin.py --physics-rates 200,800 --iterations 4/4,2/1 \
        --json "$OUT/profile_twin.json"
      ;;
    bench-sew)  # cressim demo cable's and suture's scenes
      run cable 300 python3 benchmarks/bench_cable.py --envs 1,64,1024 --json "$OUT/cable.json"
      run suture 300 python3 benchmarks/bench_suture.py --envs 1,64,1024 --json "$OUT/suture.json"
      ;;
    bench-soft)
      mkdir -p "$OUT/softbodypush" "$OUT/softbodypush_ppo"
      run softbodypush 240 python3 -m cressim bench SoftBodyPush --envs ${SOFT_ENVS:-128,256,512,1024,2048,4096,8192} \
        --mode step --out "$OUT/softbodypush"
      run softbodypush_ppo 150 python3 -m cressim bench SoftBodyPush --envs ${SOFT_PPO_ENVS:-512} --mode both \
        --out "$OUT/softbodypush_ppo"
      ;;
    bench-soft-material)  # the elastic material against XPBD compliances, and the solver knobs
      run soft_material 200 python3 benchmarks/bench_soft_material.py --envs ${SOFT_MATERIAL_ENVS:-512,4096} \
        --json "$OUT/soft_material.json"
      ;;
    bench-fluid)
      mkdir -p "$OUT/fluidpour" "$OUT/fluidpour_ppo"
      run fluidpour 200 python3 -m cressim bench FluidPour --envs ${FLUID_ENVS:-64,128,256,512,1024,2048,4096} \
        --mode step --out "$OUT/fluidpour"
      run fluidpour_ppo 120 python3 -m cressim bench FluidPour --envs ${FLUID_PPO_ENVS:-128} --mode both \
        --out "$OUT/fluidpour_ppo"
      ;;
    bench-r)  # renderer extras: culling, image-based lighting; TargetCenter with PPO
      run render_culling 150 python3 benchmarks/bench_render.py --envs 1024,4096 --sizes 64 --objects 200 \
        --culling both --raster both --json "$OUT/render_culling.json"
      run render_ibl 100 python3 benchmarks/bench_render.py --envs 1024,4096 --sizes 64,128 --raster both --ibl \
        --json "$OUT/render_ibl.json"
      mkdir -p "$OUT/targetcenter_ppo"
      run targetcenter_ppo 150 python3 -m cressim bench TargetCenter --envs 256,1024 --mode both \
        --out "$OUT/targetcenter_ppo"
      ;;
    bench-tc)  # TargetCenter at the paper's counts (step from 1) and PPO (cnn 256, minibatch 256)
      mkdir -p "$OUT/targetcenter_small" "$OUT/targetcenter_ppo"
      run targetcenter_small 90 python3 -m cressim bench TargetCenter --envs 1,8,32 --mode step \
        --out "$OUT/targetcenter_small"
      run targetcenter_ppo 300 python3 -m cressim bench TargetCenter --envs ${TC_PPO_ENVS:-32,256,1024} --mode both \
        --out "$OUT/targetcenter_ppo"
      ;;
    bench-ppo)  # end-to-end PPO at the paper's minibatches (the learner replays CUDA graphs)
      for spec in "CartPole 256,1024,4096" "SoftBodyPush 512" "FluidPour 128" "UltrasoundScan 32"; do
        read -r task counts <<< "$spec"
        mkdir -p "$OUT/ppo_$task"
        run "ppo_$task" 150 python3 -m cressim bench "$task" --envs "$counts" --mode ppo --device cuda --out "$OUT/ppo_$task"
      done
      ;;
    bench-pr)  # particles drawn by the renderer: SoftBodyPush / FluidPour worlds, a 64x64 camera per env
      run particle_render 240 python3 benchmarks/bench_particle_render.py --envs 256,1024,4096 --frames 30 \
        --raster compute --json "$OUT/particle_render.json"
      run particle_render_graphics 150 python3 benchmarks/bench_particle_render.py --envs 1024 --frames 30 \
        --raster graphics --json "$OUT/particle_render_graphics.json"
      ;;
    bench-surgical)  # TissueRetract and BloodSuction at the paper's counts and up; where a step goes
      mkdir -p "$OUT/tissueretract" "$OUT/bloodsuction" "$OUT/tissueretract_ppo" "$OUT/bloodsuction_ppo"
      run tissueretract 240 python3 -m cressim bench TissueRetract --envs ${TR_ENVS:-128,256,512,1024,2048,4096} \
        --mode step --out "$OUT/tissueretract"
      run bloodsuction 240 python3 -m cressim bench BloodSuction --envs ${BS_ENVS:-64,128,256,512,1024} \
        --mode step --out "$OUT/bloodsuction"
      run tissueretract_ppo 150 python3 -m cressim bench TissueRetract --envs 256 --mode ppo --device cuda \
        --out "$OUT/tissueretract_ppo"
      run bloodsuction_ppo 150 python3 -m cressim bench BloodSuction --envs 128 --mode ppo --device cuda \
        --out "$OUT/bloodsuction_ppo"
      run profile_tissueretract 120 python3 benchmarks/profile_task.py TissueRetract --envs 256,1024 \
        --json "$OUT/profile_tissueretract.json"
      run profile_bloodsuction 120 python3 benchmarks/profile_task.py BloodSuction --envs 128 \
        --json "$OUT/profile_bloodsuction.json"
      ;;
    bench-us)
      mkdir -p "$OUT/ultrasound"
      run ultrasound 200 python3 -m cressim bench UltrasoundScan --envs 1,8,32,64 --mode both --out "$OUT/ultrasound"
      run ultrasound_sensor 120 python3 benchmarks/bench_ultrasound.py --envs 1,32,256,1024 \
        --json "$OUT/ultrasound_sensor.json"
      ;;
    bench-us-scale)  # images/s and scatterers/s: 1 M scatterers per env at 1, 32, 1,024 envs; 10 M in one
      run ultrasound_phantom_1m 300 python3 benchmarks/bench_ultrasound.py --envs 1,32 --scatterers 1000000 \
        --json "$OUT/ultrasound_phantom_1m.json"
      run ultrasound_phantom_1m_1024 580 python3 benchmarks/bench_ultrasound.py --envs 1024 --scatterers 1000000 \
        --frames 20 --json "$OUT/ultrasound_phantom_1m_1024.json"
      run ultrasound_phantom_10m 200 python3 benchmarks/bench_ultrasound.py --envs 1 --scatterers 10000000 \
        --json "$OUT/ultrasound_phantom_10m.json"
      run ultrasound_sensor 120 python3 benchmarks/bench_ultrasound.py --envs 1,32,256,1024 \
        --json "$OUT/ultrasound_sensor.json"
      ;;
    *) echo "unknown stage $stage" >&2; exit 2 ;;
  esac
done
