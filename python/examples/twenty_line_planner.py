#!/usr/bin/env python3
"""Keep the lane, drive at the speed limit, brake for the car ahead (or cutting in): a SaFeR planner in 20 lines."""
import math, os, sys
sys.path.append(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))  # the repo's kit, if not installed
from safer_planner import Control, Planner, run, wrap_angle


class TwentyLinePlanner(Planner):
    name, min_protocol_minor = "twenty-line-planner", 1  # 1.1 or later: the whole map (`prepare`), the stable route
    cruise_mps = None  # where no speed limit is mapped: the ego's speed at the start

    def plan(self, obs):
        ego, route, s, lead = obs.ego, obs.route, obs.ego_route_s(), obs.leader(anticipate_s=1.0)
        if s is None:
            return Control(0.0, 0.0)  # no lane runs our way: coast
        self.cruise_mps = self.cruise_mps or max(ego.speed_mps, 5.0)
        lane, v = self.map.nearest_lane(ego.x, ego.y, among=route.lane_ids), ego.speed_mps
        v0 = (lane and lane[0].speed_limit_mps) or self.cruise_mps
        near = (2.5 + max(0.0, 1.4 * v + v * (v - lead.speed_mps) / 3.9)) / max(lead.gap_m, 0.1) if lead else 0.0
        accel = 1.5 * (1 - (v / v0) ** 4) - 1.5 * near**2  # IDM: free road, and a 1.4 s headway to the car ahead
        tx, ty = route.point_at(s + max(5.0, 0.9 * v))  # pure pursuit
        alpha = wrap_angle(math.atan2(ty - ego.y, tx - ego.x) - ego.heading_rad)
        yaw = 2 * max(v, 1.0) * math.sin(alpha) / max(math.hypot(tx - ego.x, ty - ego.y), 1e-6)
        return Control(max(-8.0, min(1.5, accel)), max(-1.0, min(1.0, yaw)))


run(TwentyLinePlanner)
