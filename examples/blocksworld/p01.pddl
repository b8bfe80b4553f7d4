; Invert a tower of three.
(define (problem invert-3)
  (:domain blocks)
  (:objects a b c - block)
  (:init
    (on a b)
    (on b c)
    (on-table c)
    (clear a)
    (hand-empty))
  (:goal (and (on c b) (on b a) (above c a))))
