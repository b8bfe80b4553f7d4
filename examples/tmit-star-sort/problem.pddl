(define (problem sort_2)
  (:domain sort)
  (:objects
    table_a table_b table_c -surface
    panda_hand_tcp_joint -manipulator
    red_block green_block -objs)
  (:init
    (on-surface red_block table_a)
    (on-surface green_block table_a)
    (arm-empty panda_hand_tcp_joint))
  (:goal (and
    (on-surface red_block table_b)
    (on-surface green_block table_c)
    (arm-empty panda_hand_tcp_joint))))
