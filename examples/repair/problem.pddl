; One cube on a bench in front of a Panda; the repair experiments sample where the cube is.
(define (problem pick-cube)
  (:domain pick)
  (:objects panda_hand_tcp - gripper cube - cube)
  (:init
    (empty panda_hand_tcp))
  (:goal (holding panda_hand_tcp cube)))
