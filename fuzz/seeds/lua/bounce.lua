-- A ball rolls across a slab and the camera swings around it: one second
-- at 24 fps.
--   yubin render scenes/animation/bounce.lua --frames 1-24 -o out/bounce_####.png --video out/bounce.mp4
-- The script runs once per frame with `frame` and `time` (seconds) set;
-- what it changes between frames (the ball's and the camera's transforms,
-- the light) is updated in the scene, not rebuilt.

local t = (frame - 1) / 23                 -- 0 at the first frame, 1 at the last

red = gr.material({albedo = {0.8, 0.15, 0.1}, roughness = 0.3})
grey = gr.material({albedo = gr.const(0.5), roughness = 0.8})

root = gr.node("root")

ball = gr.sphere("ball")
ball:set_material(red)
local x = ease.between(-2.5, 2.5, t, ease.in_out_cubic)
local hop = 1 + 1.5 * math.abs(math.sin(2 * math.pi * ease.cosine(t)))
ball:scale(0.75)
ball:translate(x, hop, 0)
root:add_child(ball)

floor = gr.cube("floor")
floor:scale(12, 0.25, 6)
floor:translate(-6, -0.25, -3)
floor:set_material(grey)
root:add_child(floor)

local angle = math.rad(ease.between(-25, 25, t, ease.cosine))
gr.render{scene = root, output = "bounce_####.png", width = 320, height = 180, spp = 32,
  eye = {10 * math.sin(angle), 3, 10 * math.cos(angle)}, target = {0, 1, 0}, up = {0, 1, 0},
  fov = 35, lights = {gr.light({3, 7, 4}, {80, 80, 80 * (0.6 + 0.4 * t)})},
  ambient = {0.1, 0.1, 0.12}}
