// Writes ROS 2 bags from a recording's messages (log_to_json.py's JSON lines) with
// independent implementations: @mcap/core (MCAP container) and
// @foxglove/rosmsg2-serialization (CDR), never agvcal's own code.
//   node write_bags.mjs MESSAGES.jsonl MAPPING.json OUT.mcap COMPRESSION [CDR.jsonl]
// COMPRESSION: none, zstd or lz4. CDR.jsonl (optional): every serialized message as
// {topic, type, record_ns, data (hex)}, for write_db3.py.
// MAPPING.json: {"wheel_joints": {name: joint}, "steer_joints": {name: joint},
//                "scan_frame": "laser", "lidar2d": {x, y, yaw} | null, "imu_topic": "/imu"}
// Record times are the header stamps plus a latency of each topic's own, so that an importer
// using record times instead of header stamps gets other numbers.
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import * as zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";
import fs from "node:fs";
import readline from "node:readline";

const [input, mappingPath, output, compression, cdrPath] = process.argv.slice(2);
const mapping = JSON.parse(fs.readFileSync(mappingPath, "utf8"));

const MSG = {
  "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
  "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
  "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
  "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
  "geometry_msgs/PoseWithCovariance": "geometry_msgs/Pose pose\nfloat64[36] covariance",
  "geometry_msgs/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular",
  "geometry_msgs/TwistWithCovariance": "geometry_msgs/Twist twist\nfloat64[36] covariance",
  "geometry_msgs/TwistStamped": "std_msgs/Header header\ngeometry_msgs/Twist twist",
  "geometry_msgs/Transform": "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation",
  "geometry_msgs/TransformStamped":
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform",
  "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
  "sensor_msgs/JointState":
    "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort",
  "sensor_msgs/LaserScan":
    "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n" +
    "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n" +
    "float32[] ranges\nfloat32[] intensities",
  "sensor_msgs/Imu":
    "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n" +
    "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n" +
    "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance",
  "nav_msgs/Odometry":
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n" +
    "geometry_msgs/TwistWithCovariance twist",
};

// The full definition text (the type, then each dependency once), as ROS 2 bags store it.
function definition(type) {
  const seen = new Set([type]);
  const order = [];
  const visit = (t) => {
    for (const line of MSG[t].split("\n")) {
      const field = line.split(" ")[0].replace(/\[\d*\]$/, "");
      if (field.includes("/") && !seen.has(field)) {
        seen.add(field);
        order.push(field);
        visit(field);
      }
    }
  };
  visit(type);
  const sep = "=".repeat(80);
  return [MSG[type], ...order.map((t) => `${sep}\nMSG: ${t}\n${MSG[t]}`)].join("\n");
}

const writers = new Map();
function serialize(type, message) {
  if (!writers.has(type)) writers.set(type, new MessageWriter(parse(definition(type), { ros2: true })));
  return writers.get(type).writeMessage(message);
}

const num = (v) => (typeof v === "string" ? Number(v) : v);  // "NaN", "Infinity" from the JSON
const header = (utime, frame) => ({
  stamp: { sec: Math.floor(utime / 1e6), nanosec: (utime % 1e6) * 1000 },
  frame_id: frame,
});
const quaternion = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });

// One ROS message per recording message: [topic, type, message] or null.
function convert(m) {
  if (m.channel === "WHEELS") {
    const names = [], position = [], velocity = [];
    m.name.forEach((wheel, i) => {
      names.push(mapping.wheel_joints[wheel]);
      position.push(num(m.position[i]));
      velocity.push(num(m.velocity[i]));
      if (mapping.steer_joints && mapping.steer_joints[wheel]) {
        names.push(mapping.steer_joints[wheel]);
        position.push(num(m.steer[i]));
        velocity.push(0);
      }
    });
    const reported = velocity.some((v) => !Number.isNaN(v));
    return ["/joint_states", "sensor_msgs/JointState", {
      header: header(m.utime, ""), name: names, position,
      velocity: reported ? velocity : [], effort: [] }];
  }
  if (m.channel === "SCAN") {
    const ranges = m.ranges.map(num);
    return ["/scan", "sensor_msgs/LaserScan", {
      header: header(m.utime, mapping.scan_frame), angle_min: m.angle_min,
      angle_max: m.angle_min + m.angle_increment * (ranges.length - 1),
      angle_increment: m.angle_increment, time_increment: m.time_increment, scan_time: m.scan_time,
      range_min: m.range_min, range_max: m.range_max, ranges: Float32Array.from(ranges),
      intensities: Float32Array.from(m.intensities.map(num)) }];
  }
  if (m.channel === "POSE") {
    const c = m.cov, covariance = new Array(36).fill(0), idx = [0, 1, 5];
    for (let r = 0; r < 3; r++) for (let k = 0; k < 3; k++) covariance[6 * idx[r] + idx[k]] = c[3 * r + k];
    return ["/odom", "nav_msgs/Odometry", {
      header: header(m.utime, "odom"), child_frame_id: "base_link",
      pose: { pose: { position: { x: m.x, y: m.y, z: 0 }, orientation: quaternion(m.theta) }, covariance },
      twist: { twist: { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } },
               covariance: new Array(36).fill(0) } }];
  }
  if (m.channel === "IMU") {
    const v = (a) => ({ x: a[0], y: a[1], z: a[2] });
    return [mapping.imu_topic ?? "/imu", "sensor_msgs/Imu", {
      header: header(m.utime, "imu"), orientation: { x: 0, y: 0, z: 0, w: 1 },
      orientation_covariance: new Array(9).fill(0), angular_velocity: v(m.angular_velocity),
      angular_velocity_covariance: new Array(9).fill(0), linear_acceleration: v(m.linear_acceleration),
      linear_acceleration_covariance: new Array(9).fill(0) }];
  }
  if (m.channel === "DRIVE_CMD" && m.mode === 0) {
    return ["/cmd_vel", "geometry_msgs/TwistStamped", {
      header: header(m.utime, "base_link"),
      twist: { linear: { x: m.vx, y: m.vy, z: 0 }, angular: { x: 0, y: 0, z: m.omega } } }];
  }
  return null;
}

const compressors = {
  none: undefined,
  zstd: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }),
  lz4: (data) => ({ compression: "lz4", compressedData: Uint8Array.from(lz4.compress(data)) }),
};

async function main() {
  await zstd.isLoaded;
  const chunks = [];
  let size = 0n;
  const writable = {
    position: () => size,
    write: async (buffer) => { chunks.push(Buffer.from(buffer)); size += BigInt(buffer.byteLength); },
  };
  const writer = new McapWriter({ writable, chunkSize: 256 * 1024,
                                  compressChunk: compressors[compression], useChunks: true });
  await writer.start({ profile: "ros2", library: "tests/ros/write_bags.mjs" });
  const channels = new Map();
  const cdr = cdrPath ? fs.createWriteStream(cdrPath) : null;
  const latencyMs = { "/joint_states": 2, "/scan": 15 };
  const add = async (topic, type, message, utime) => {
    if (!channels.has(topic)) {
      const schemaId = await writer.registerSchema({
        name: type.replace("/", "/msg/"), encoding: "ros2msg",
        data: new TextEncoder().encode(definition(type)) });
      channels.set(topic, await writer.registerChannel({
        topic, schemaId, messageEncoding: "cdr", metadata: new Map() }));
    }
    const data = serialize(type, message);
    const record = BigInt(utime) * 1000n + BigInt(latencyMs[topic] ?? 5) * 1000000n;
    await writer.addMessage({ channelId: channels.get(topic), sequence: 0, logTime: record,
                              publishTime: record, data });
    if (cdr) cdr.write(JSON.stringify({ topic, type: type.replace("/", "/msg/"),
                                        record_ns: record.toString(),
                                        data: Buffer.from(data).toString("hex") }) + "\n");
  };
  let first = true;
  const lines = readline.createInterface({ input: fs.createReadStream(input) });
  for await (const line of lines) {
    if (!line) continue;
    const m = JSON.parse(line);
    if (first && mapping.lidar2d) {  // the nominal lidar mount, as a robot's tf_static has it
      const l = mapping.lidar2d;
      await add("/tf_static", "tf2_msgs/TFMessage", { transforms: [{
        header: header(m.utime, "base_link"), child_frame_id: mapping.scan_frame,
        transform: { translation: { x: l.x, y: l.y, z: 0.3 }, rotation: quaternion(l.yaw) } }] },
        m.utime);
    }
    first = false;
    const converted = convert(m);
    if (converted) await add(converted[0], converted[1], converted[2], m.utime);
  }
  await writer.end();
  fs.writeFileSync(output, Buffer.concat(chunks));
  if (cdr) await new Promise((resolve) => cdr.end(resolve));
}

main().catch((e) => { console.error(e); process.exit(1); });
