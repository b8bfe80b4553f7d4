(define (domain sort)
  (:requirements :strips :equality)
  (:predicates
    (on-surface ?x -objs ?s -surface :discrete)
    (arm-empty ?m -manipulator :discrete)
    (holding ?m -manipulator ?x -objs :kinematic ((link ?m ?x) (unlink ?m ?x)))
    (at ?m -manipulator ?x -objs)
    (above ?m -manipulator ?s -surface))

  (:action pickup
    :parameters (?x -objs ?s -surface ?m -manipulator)
    :precondition (and (on-surface ?x ?s) (arm-empty ?m) (at ?m ?x))
    :effect (and (holding ?m ?x) (not (on-surface ?x ?s)) (not (arm-empty ?m))))

  (:action putdown
    :parameters (?x -objs ?s -surface ?m -manipulator)
    :precondition (and (holding ?m ?x) (above ?m ?s))
    :effect (and (arm-empty ?m) (on-surface ?x ?s) (not (holding ?m ?x)))))
