// CPU backend of the collider: Embree 3 scenes, rays cast in parallel with oneTBB.
#pragma once
#include <memory>

#include "collide/collider.h"

namespace raycloth {

std::unique_ptr<Collider> make_embree_collider();

}  // namespace raycloth
