// Where a POI may stand, as the map manager judges it (nodes/map_manager/placement.py, the same
// rule and figures): on a known free cell of /map, at least the robot's clearance from every
// obstacle. The console warns with it while the operator places a POI, before anything is sent;
// the map manager refuses such a POI anyway, with the reason.

export const ROBOT_RADIUS = 0.2; // m, the simulated robot's footprint (placement.py says why)
export const SAFETY_MARGIN = 0.05; // m, its planner's margin
export const CLEARANCE = ROBOT_RADIUS + SAFETY_MARGIN;
const OCCUPIED_FROM = 65; // occupancy values from here up are obstacles (map_server's 0.65)
const UNKNOWN = -1;

/** The distance from (x, y) to the nearest obstacle cell's edge, if under `within` (else null). */
function nearestObstacle(grid, col, row, x, y, within) {
  const { resolution: res, width, height, origin } = grid.info;
  const reach = Math.ceil(within / res) + 1;
  let nearest = Infinity;
  for (let r = Math.max(row - reach, 0); r < Math.min(row + reach + 1, height); r += 1) {
    for (let c = Math.max(col - reach, 0); c < Math.min(col + reach + 1, width); c += 1) {
      if (grid.data[r * width + c] < OCCUPIED_FROM) continue;
      const dx = Math.max(Math.abs(origin.position.x + (c + 0.5) * res - x) - res / 2, 0);
      const dy = Math.max(Math.abs(origin.position.y + (r + 0.5) * res - y) - res / 2, 0);
      nearest = Math.min(nearest, Math.hypot(dx, dy));
    }
  }
  return nearest < within ? nearest : null;
}

/** Why a POI cannot stand at (x, y) on `grid` (a nav_msgs/OccupancyGrid), in the operator's
 * words; '' when it can, or when there is no map yet. */
export function placementProblem(grid, x, y) {
  if (!grid || !grid.info || !grid.data) return '';
  const { resolution: res, width, height, origin } = grid.info;
  const col = Math.floor((x - origin.position.x) / res);
  const row = Math.floor((y - origin.position.y) / res);
  if (col < 0 || row < 0 || col >= width || row >= height) return 'this spot is outside the map';
  const value = grid.data[row * width + col];
  if (value === UNKNOWN) return 'this spot is on an unexplored part of the map';
  if (value >= OCCUPIED_FROM) return 'this spot is on an obstacle';
  const near = nearestObstacle(grid, col, row, x, y, CLEARANCE);
  if (near === null) return '';
  return `this spot is ${near.toFixed(2)} m from an obstacle; the robot needs ` +
    `${CLEARANCE.toFixed(2)} m (its ${ROBOT_RADIUS.toFixed(2)} m radius and a ` +
    `${SAFETY_MARGIN.toFixed(2)} m margin)`;
}
