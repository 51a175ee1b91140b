// The volume family's passes (particle_solve.hlsli); its constraint is in particle_volume.hlsli.
#include "particle_constraint.hlsli"
#include "particle_volume.hlsli"
#define evaluate evaluate_volume
#include "particle_solve.hlsli"
